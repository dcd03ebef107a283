"""A sweep process whose DAQ freezes ends, within a bounded time, with the ram stopped,
centred and disabled (seen by an independent Modbus client), and says why: the frozen
stream is a fatal error, and nothing in the teardown waits for frames that never come."""

from __future__ import annotations

import subprocess
import time

from stop_helpers import Probe, reap, rig_file_for, spawn_sweep, wait_test_running

from shockdyno.record import open_recording
from shockdyno.simrig.faults import Fault

# The session sees the freeze after daq.frozen_timeout_s (1 s); the stop, the ramp to
# centre (driven by the drive's own position, the DAQ being what failed) and the disable
# take a few seconds more. A teardown waiting on frames would run on past this.
BOUND_S = 20.0


def test_a_sweep_whose_daq_freezes_exits_promptly_with_the_drive_disabled(
    sim_rig_factory, tmp_path
):
    sim = sim_rig_factory(speed=4.0)
    out = tmp_path / "rec.mcap"
    proc = spawn_sweep(rig_file_for(sim, tmp_path), out)
    probe = Probe(sim)
    try:
        wait_test_running(out, proc, limit_s=30)
        time.sleep(0.3)
        sim.inject(Fault("freeze"))
        t0 = time.monotonic()
        disabled = probe.wait_for(lambda s: not s.enabled and not s.running, limit_s=BOUND_S)
        try:
            _, err = proc.communicate(timeout=BOUND_S)
        except subprocess.TimeoutExpired:
            err = b""
        took = time.monotonic() - t0
        final = probe.status()
        print(f"exit {proc.returncode} {took:.2f} s after the freeze")
    finally:
        probe.close()
        reap(proc)
    text = (err or b"").decode(errors="replace")
    assert proc.returncode not in (0, None), text
    assert took < BOUND_S, f"the sweep ran on {took:.1f} s after its DAQ froze"
    assert "Traceback" not in text and "DAQ frozen" in text.strip().splitlines()[-1]
    assert disabled is not None, "the drive was left enabled or running"
    assert final is not None and not final.enabled and not final.running
    assert abs(final.position_m - sim.rig.stroke_centre_m) < 0.001  # centred on its own reading
    rec = open_recording(out)
    assert not rec.truncated  # the recording was closed, with the story in it
    kinds = [k for _, k, _ in rec.events]
    assert {"daq_frozen", "stop", "centre", "disable", "closed"} <= set(kinds)
    assert kinds.index("stop") < kinds.index("disable")
