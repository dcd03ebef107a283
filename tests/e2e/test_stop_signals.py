"""Every way a sweep process can be ended leaves the ram stopped, centred and disabled, seen
by an independent Modbus client, and the recording holds what happened."""

from __future__ import annotations

import signal
import subprocess
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

from shockdyno.record import open_recording


def _finish(proc: subprocess.Popen[bytes], timeout: float = 30) -> bytes:
    try:
        _, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return err or b""


# SIGINT alone: test_sweep_e2e.py::test_ctrl_c_stops_safely_and_keeps_what_was_recorded
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_signal_mid_test_stops_centres_disables_and_records_why(sim_rig_factory, tmp_path, sig):
    sim = sim_rig_factory(speed=4.0)
    out = tmp_path / "rec.mcap"
    proc = spawn_sweep(rig_file_for(sim, tmp_path), out)
    probe = Probe(sim)
    try:
        wait_test_running(out, proc, limit_s=30)
        proc.send_signal(sig)
        stopped = probe.wait_for(lambda s: not s.running, limit_s=5)
        disabled = probe.wait_for(lambda s: not s.enabled, limit_s=5)
        err = _finish(proc)
        final = probe.status()
    finally:
        probe.close()
        reap(proc)
    assert stopped is not None and disabled is not None, "ram left running or enabled"
    assert proc.returncode == 128 + sig, err
    assert b"Traceback" not in err
    assert final is not None and not final.enabled and not final.running and not final.fault
    rec = open_recording(out)
    story = "; ".join(f"{k}: {m}" for _, k, m in rec.events[-8:])
    assert abs(final.position_m - sim.rig.stroke_centre_m) < 0.001, story  # centred
    assert not rec.truncated and not rec.interrupted
    name = signal.Signals(sig).name if sig != signal.SIGINT else "Ctrl-C"
    kinds = [k for _, k, _ in rec.events]
    assert {"connect", "enable", "start", "exit", "stop", "centre", "disable"} <= set(kinds)
    assert kinds.index("exit") < kinds.index("disable")
    assert any(k == "exit" and name in m for _, k, m in rec.events)
    aborted = [m for m in rec.tests if m.status == "aborted"]
    assert len(aborted) == 1 and name in (aborted[0].abort_reason or "")


def test_second_ctrl_c_does_not_cut_the_stop_short(sim_rig_factory, tmp_path):
    sim = sim_rig_factory(speed=4.0)
    out = tmp_path / "rec.mcap"
    proc = spawn_sweep(rig_file_for(sim, tmp_path), out)
    probe = Probe(sim)
    try:
        wait_test_running(out, proc, limit_s=30)
        proc.send_signal(signal.SIGINT)
        time.sleep(0.1)
        proc.send_signal(signal.SIGINT)
        err = _finish(proc)
        final = probe.status()
    finally:
        probe.close()
        reap(proc)
    assert proc.returncode == 130, err
    assert final is not None and not final.enabled and not final.running
    assert abs(final.position_m - sim.rig.stroke_centre_m) < 0.001
    kinds = {k for _, k, _ in open_recording(out).events}
    assert {"abort", "exit", "stop", "centre", "disable", "closed"} <= kinds


def test_kill_9_keeps_every_event_before_it_and_the_watchdog_disables(sim_rig_factory, tmp_path):
    sim = sim_rig_factory(speed=4.0)
    out = tmp_path / "rec.mcap"
    proc = spawn_sweep(rig_file_for(sim, tmp_path), out)
    probe = Probe(sim)
    try:
        wait_complete_tests(out, 1, proc, limit_s=60)
        wait_test_running(out, proc, limit_s=30)  # killed inside the second test
        proc.kill()
        _finish(proc, timeout=10)
        # No host any more: the drive's own watchdog (heartbeat_timeout_s 0.5) must act.
        disabled = probe.wait_for(lambda s: not s.enabled and not s.running, limit_s=3)
    finally:
        probe.close()
        reap(proc)
    assert disabled is not None and disabled < 2.0
    rec = open_recording(out)
    assert rec.truncated
    kinds = [k for _, k, _ in rec.events]
    # Written as they happened: the first test's whole story and the second's start.
    assert kinds[:4] == ["connect", "enable", "centre", "adjust"]
    assert kinds.count("start") == 2 and "complete" in kinds
    assert [m.status for m in rec.tests] == ["complete"]


def test_an_output_that_cannot_be_created_is_refused_before_the_ram_moves(
    sim_rig_factory, tmp_path, capsys
):
    from shockdyno.cli import main

    sim = sim_rig_factory(speed=4.0)
    probe = Probe(sim)
    try:
        parked = probe.status()
        code = main(["sweep", "--rig", str(rig_file_for(sim, tmp_path)), "-o", "/proc/x.mcap"])
        after = probe.status()
    finally:
        probe.close()
    assert code == 2 and "cannot create files in /proc" in capsys.readouterr().err
    assert parked is not None and after is not None and not after.enabled
    assert after.position_m == pytest.approx(parked.position_m, abs=1e-5)  # never moved
