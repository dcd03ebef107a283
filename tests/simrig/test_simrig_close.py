"""A simulated rig whose plant is stuck in a step still closes, and its process still
exits: `sweep --start-sim` printed its error (DAQ frozen: the plant's step never came
back), and then never ended, its plant's worker thread joined at interpreter exit."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from shockdyno.simrig.server import STEP_WAIT_S

REPO = Path(__file__).resolve().parents[2]

SCRIPT = """
import sys, threading, time
from shockdyno.simrig import start_sim_rig
sim = start_sim_rig(sys.argv[1], scenario=sys.argv[2], speed=1.0)
forever = threading.Event()
stepped = threading.Event()
def stuck(n):
    stepped.set()
    forever.wait()  # a step that never returns
    return b""
sim.engine.advance = stuck
assert stepped.wait(30), "no step taken"
print("stuck", flush=True)
time.sleep(0.2)
t0 = time.monotonic()
sim.close()
print(f"closed {time.monotonic() - t0:.2f}", flush=True)
"""


def test_a_plant_stuck_in_a_step_does_not_keep_the_process_alive(tmp_path: Path) -> None:
    sc = tmp_path / "ref.toml"
    sc.write_text('[scenario]\nname = "r"\n[plant]\nkind = "reference"\n')
    proc = subprocess.Popen(
        [sys.executable, "-c", SCRIPT, str(REPO / "rigs/sim.toml"), str(sc)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()  # the start (a first compile) is not what is timed
        assert line.strip() == "stuck", line + proc.stderr.read() if proc.stderr else ""
        t0 = time.monotonic()
        out, err = proc.communicate(timeout=STEP_WAIT_S + 20)
        took = time.monotonic() - t0
    except subprocess.TimeoutExpired:
        pytest.fail("the process did not exit after its simulated rig was closed")
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()
    assert proc.returncode == 0, err
    closed = float(out.split()[-1])
    # the close waits STEP_WAIT_S for the step, then the servers shut down
    assert STEP_WAIT_S - 0.1 < closed < STEP_WAIT_S + 5, out
    assert took < STEP_WAIT_S + 15
