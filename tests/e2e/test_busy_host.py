"""A busy host (issue 46.12): with twice as many CPU-bound processes as cores besides it, a
real sweep process against the simulated rig keeps its control loop alive (the drive's
watchdog never trips), records complete tests, and still stops, centres and disables on
SIGTERM. Under a load of 5-7 on 2 cores the suite once failed 'heartbeat lost' and 'ram
left running or enabled'.

The guarantee rests on the control loop's raised priority (shockdyno/priority.py): where the
process may not raise it, the test is skipped, since a starved loop then stops the drive,
which is safe but not a sweep."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import pytest
from stop_helpers import (
    Probe,
    reap,
    rig_file_for,
    spawn_sweep,
    wait_complete_tests,
    wait_test_running,
)

from shockdyno import priority
from shockdyno.record import open_recording


def _may_raise_priority() -> bool:
    before, said = priority.raise_priority()
    priority.restore(before)
    return before is not None or "already" in said


pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not _may_raise_priority(), reason="may not raise the loop's priority"),
]

BURN = "import time\nend = time.monotonic() + 120\nwhile time.monotonic() < end:\n    pass\n"


@pytest.fixture
def burners():  # type: ignore[no-untyped-def]
    """2x cores of CPU-bound processes at the normal priority, for the test's length."""
    n = 2 * (os.cpu_count() or 1)
    procs = [subprocess.Popen([sys.executable, "-c", BURN]) for _ in range(n)]
    yield n
    for p in procs:
        p.kill()
        p.wait()


def test_a_sweep_under_twice_the_cores_of_load_keeps_its_watchdog_fed_and_stops(
    sim_rig_factory, tmp_path, burners
) -> None:
    sim = sim_rig_factory(speed=4.0)
    out = tmp_path / "busy.mcap"
    proc = spawn_sweep(rig_file_for(sim, tmp_path), out)
    probe = Probe(sim)
    try:
        wait_complete_tests(out, 1, proc, limit_s=90)
        wait_test_running(out, proc, limit_s=60)
        sent = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        disabled = probe.wait_for(lambda s: not s.enabled and not s.running, limit_s=10)
        _, err = proc.communicate(timeout=60)
        final = probe.status()
    finally:
        probe.close()
        reap(proc)
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert disabled is not None, "ram left running or enabled"
    assert final is not None and abs(final.position_m - sim.rig.stroke_centre_m) < 0.001
    stops = [t for t, word in sim.registers.control_log if t >= sent and word & 0b100]
    assert stops, "no stop command on the wire"
    rec = open_recording(out)
    assert rec.tests[0].status == "complete"
    kinds = [k for _, k, _ in rec.events]
    assert "link_lost" not in kinds and "actuator_fault" not in kinds
    closed = next(m for _, k, m in rec.events if k == "closed")
    gap, watchdog = map(int, re.findall(r"(\d+) ms", closed))
    assert gap < watchdog, closed  # the loop beat in time, all through
    assert "nice -10" in next(m for _, k, m in rec.events if k == "connect")
