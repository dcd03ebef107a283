"""Click sweeps end to end: simulated rig on real wires -> RigSession -> MCAP -> reader."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from inprocess import cli
from shockdyno.errors import RecordingError
from shockdyno.fit import fit_sweep
from shockdyno.model.spec import default_spec_path, load_spec
from shockdyno.record import RecordingWriter, open_recording
from shockdyno.report.clickchart import spec_static_force_n
from shockdyno.run.liveview import LiveView
from shockdyno.run.plan import SweepPlan
from shockdyno.run.session import RigSession
from shockdyno.run.sweep import run_sweep
from shockdyno.samples import SampleBlock
from shockdyno.simrig import start_sim_rig

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "rigs" / "sim.toml"
CLI = [sys.executable, "-m", "shockdyno.cli"]


class TeeWriter(RecordingWriter):
    """The real writer, keeping a copy of every block the rig delivered."""

    def __init__(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        super().__init__(*args, **kwargs)
        self.sent: list[SampleBlock] = []  # inside tests
        self.outside: list[SampleBlock] = []  # between tests: the gas-force measurements

    def write_samples(self, block: SampleBlock) -> None:
        (self.sent if self._open is not None else self.outside).append(block)
        super().write_samples(block)


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """One small sweep on the simulated rig, recorded, with what the rig sent kept aside."""
    out = tmp_path_factory.mktemp("sweep") / "sweep.mcap"
    plan = SweepPlan(clicks=(3, 12), frequencies_hz=(1.0, 1.5), warmup_cycles=1, measured_cycles=3)
    with start_sim_rig(SIM_RIG, speed=40, seed=7) as sim:
        rig = sim.rig_config()
        truth = {c: tuple(float(a) for a in sim.true_bleed_areas(c, 0)) for c in plan.clicks}
        with (
            TeeWriter(out, metadata={"damper_id": "e2e"}, rig_toml=rig.raw_toml) as writer,
            LiveView(len(plan.points()), enabled=False) as view,
            RigSession(rig) as session,
        ):
            result = run_sweep(session, plan, writer, view, sample_rate_hz=rig.sample_rate_hz)
    return out, plan, writer.sent, result, truth, writer.outside


def test_recording_reads_back_exactly_what_the_rig_sent(swept):
    path, plan, sent, result, *_ = swept
    rec = open_recording(path)
    assert not rec.truncated
    assert [(m.clicks, m.frequency_hz) for m in rec.tests] == [p.key[::2] for p in plan.points()]
    assert all(m.status == "complete" for m in rec.tests) and len(result.completed) == 4
    everything = SampleBlock.concat(sent)
    got = SampleBlock.concat([rec.samples(i) for i in range(len(rec.tests))])
    assert len(everything) > 4 * 3 * 600  # 3 measured cycles of >= 0.67 s at 1 kHz, per test
    np.testing.assert_array_equal(got.seq, everything.seq)
    np.testing.assert_array_equal(got.t_s, everything.t_s)
    np.testing.assert_array_equal(got.displacement_m, everything.displacement_m)
    np.testing.assert_array_equal(got.force_n, everything.force_n)
    # The time base is the DAQ counter: 1 ms steps with no gaps (no dropped frames).
    assert np.all(np.diff(got.seq) > 0)
    for i, meta in enumerate(rec.tests):
        block = rec.samples(i)
        assert np.all(np.diff(block.seq) == 1), f"test {i} dropped frames"
        assert meta.dropped_frames == 0
        assert meta.measured_start_s is not None and meta.measured_end_s is not None
        measured = meta.measured_end_s - meta.measured_start_s
        assert measured == pytest.approx(3 / meta.frequency_hz, rel=0.02)
    assert rec.rig_toml is not None and "[actuator" in rec.rig_toml
    assert rec.metadata["damper_id"] == "e2e"


def test_sweep_measures_the_gas_force_at_each_click_change(swept):
    path, plan, _, _, _, outside = swept
    rec = open_recording(path)
    # The simulated damper's force at rest at mid-stroke: (p_gas - p_atm) A_rod.
    truth = spec_static_force_n(load_spec())
    assert truth == pytest.approx(230.7, abs=0.1)
    for meta in rec.tests:
        assert meta.gas_force_source == "measured"
        assert meta.gas_force_n == pytest.approx(truth, abs=1.0)  # noise 2 N over 350 samples
    # Once per click setting, each from its own rests (the samples are in the recording,
    # outside any test), and the two approaches agree: nothing hysteretic in this damper.
    events = [e for e in rec.events if e[1] == "gas_force"]
    assert len(events) == len(plan.clicks)
    moved = SampleBlock.concat(outside)
    assert np.ptp(moved.displacement_m) == pytest.approx(0.010, abs=0.001)  # ±5 mm


def test_measured_cycles_are_the_commanded_sine(swept):
    path, *_ = swept
    rec = open_recording(path)
    for i, meta in enumerate(rec.tests):
        test = rec.load(i).measured()
        w = 2 * np.pi * meta.frequency_hz
        # Least-squares sine at the commanded frequency: amplitude within 2 % of 30 mm.
        basis = np.column_stack([np.sin(w * test.t), np.cos(w * test.t), np.ones_like(test.t)])
        coef, *_ = np.linalg.lstsq(basis, test.x, rcond=None)
        assert np.hypot(coef[0], coef[1]) == pytest.approx(meta.amplitude_m, rel=0.02)
        assert abs(coef[2]) < 1e-3  # centred


def test_fit_of_a_simulated_sweep_recovers_the_true_bleed_areas(swept):
    path, _, _, _, truth, _ = swept
    tests = open_recording(path).load_all()
    result = fit_sweep(tests, default_spec_path(), optimizer="fast", seed=0)
    for c in result.clicks:
        true_bc, true_bt = truth[c.clicks]
        assert c.identifiable_bc and c.identifiable_bt
        assert c.a_bc_m2 == pytest.approx(true_bc, rel=0.10)
        assert c.a_bt_m2 == pytest.approx(true_bt, rel=0.10)
        assert abs(c.a_bc_m2 - true_bc) <= 3 * c.a_bc_sd_m2 + 1e-3 * true_bc
    assert all(t.proposed["E_t"] <= 0.05 for t in result.tests)


def _sweep_args(out: Path, *extra: str) -> list[str]:
    return [
        "sweep", "--rig", str(SIM_RIG), "--start-sim", "--clicks", "0,10,20",
        "--freq", "1,1.5", "--cycles", "2", "--warmup-cycles", "1", "-o", str(out), *extra,
    ]  # fmt: skip


def _sweep_cmd(out: Path, *extra: str) -> list[str]:
    return [*CLI, *_sweep_args(out, *extra)]


def _wait_for_complete_tests(path: Path, n: int, proc: subprocess.Popen[bytes], limit_s: float):
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        assert proc.poll() is None, "the sweep ended before it could be interrupted"
        if path.exists():
            try:
                if sum(m.status == "complete" for m in open_recording(path).tests) >= n:
                    return
            except RecordingError:  # caught between writes before its header is out; retry
                pass
        time.sleep(0.2)
    raise AssertionError(f"no {n} complete tests within {limit_s} s")


def test_kill_mid_sweep_keeps_completed_tests_and_resume_finishes(tmp_path):
    out = tmp_path / "killed.mcap"
    log = (tmp_path / "killed.log").open("wb")
    proc = subprocess.Popen(_sweep_cmd(out, "--speed", "4"), cwd=REPO, stdout=log,
                            stderr=log)  # fmt: skip
    try:
        _wait_for_complete_tests(out, 2, proc, limit_s=60)
        proc.send_signal(signal.SIGKILL)  # power loss: no teardown, no close
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        log.close()
    rec = open_recording(out)
    done = rec.completed_keys()
    assert len(done) >= 2
    for i, meta in enumerate(rec.tests):
        if meta.status == "complete":
            assert rec.load(i).t.size > 1000
    resumed = cli(*_sweep_args(out, "--speed", "40", "--resume"))
    assert resumed.returncode == 0, resumed.stderr
    final = open_recording(out)
    expected = {(c, 0, f) for c in (0, 10, 20) for f in (1.0, 1.5)}
    assert final.completed_keys() == expected
    # The first run's completed tests are still there, untouched.
    assert done <= final.completed_keys()


def test_ctrl_c_stops_safely_and_keeps_what_was_recorded(tmp_path):
    out = tmp_path / "interrupted.mcap"
    proc = subprocess.Popen(_sweep_cmd(out, "--speed", "4"), cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)  # fmt: skip
    try:
        _wait_for_complete_tests(out, 1, proc, limit_s=60)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130
    assert b"Traceback" not in err
    rec = open_recording(out)
    assert not rec.truncated  # closed properly
    assert not rec.interrupted  # no test left begun but not ended
    complete = [m for m in rec.tests if m.status == "complete"]
    assert 1 <= len(complete) < 6
    # SIGINT inside a test marks that test aborted with the operator's reason; landing
    # between two tests, there is no test to mark, and nothing else may be lost.
    # The teardown is in the recording: interrupted, stopped, centred, disabled.
    kinds = {kind: message for _, kind, message in rec.events}
    assert "Ctrl-C" in kinds["exit"]
    assert {"stop", "centre", "disable"} <= kinds.keys()
    for meta in rec.tests:
        assert meta.status in ("complete", "aborted")
        if meta.status == "aborted":
            assert "Ctrl-C" in (meta.abort_reason or "")
            assert any("Ctrl-C" in e[2] for e in rec.events)


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (("--amplitude-mm", "500"), "travel"),  # beyond the rig's ±45 mm
        (("--amplitude-mm", "40", "--freq", "5"), "velocity"),  # 2πfA = 1.26 m/s > 0.6 m/s
        (("--gas-clicks", "99"), "gas-bottle clicks"),
    ],
)
def test_bad_plans_are_refused_in_one_line_before_anything_moves(tmp_path, flags, words):
    out = tmp_path / "absurd.mcap"
    res = cli(*_sweep_args(out, "--speed", "40", *flags))
    assert res.returncode == 2
    assert "Traceback" not in res.stderr
    errors = [line for line in res.stderr.splitlines() if "error" in line]
    assert len(errors) == 1 and words in errors[0]
    assert not out.exists()  # refused before connecting: no recording, nothing moved


def test_operator_adjuster_without_a_terminal_is_refused_before_anything_moves(tmp_path):
    rig = tmp_path / "operator.toml"
    rig.write_text(SIM_RIG.read_text().replace('adjuster = "motorised"', 'adjuster = "operator"'))
    out = tmp_path / "op.mcap"
    args = ["sweep", "--rig", str(rig), "--start-sim", "--clicks", "0", "--freq", "1",
            "-o", str(out)]  # fmt: skip
    res = cli(*args, stdin="")
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "terminal" in res.stderr and not out.exists()


def test_resume_with_a_different_plan_is_refused(swept):
    path, *_ = swept
    before = path.read_bytes()
    args = ["sweep", "--rig", str(SIM_RIG), "--start-sim", "--speed", "40", "--clicks",
            "3,12,15", "--freq", "1,1.5", "--warmup-cycles", "1", "--cycles", "3",
            "--amplitude-mm", "20", "--resume", "-o", str(path)]  # fmt: skip
    res = cli(*args)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "--resume must use the same" in res.stderr
    assert path.read_bytes() == before
    assert not list(path.parent.glob("*.part*.mcap"))


def test_a_path_that_is_a_file_is_a_one_line_error(tmp_path):
    blocker = tmp_path / "not-a-dir"
    blocker.write_text("")
    res = cli("demo", "--no-fit", "--out-dir", str(blocker))
    assert res.returncode == 2
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert str(blocker) in res.stderr


def test_existing_recording_is_not_overwritten(tmp_path):
    out = tmp_path / "keep.mcap"
    out.write_bytes(b"precious")
    res = cli(*_sweep_args(out, "--speed", "40"))
    assert res.returncode != 0 and "--force" in res.stderr
    assert out.read_bytes() == b"precious"


@pytest.mark.skipif(os.environ.get("SHOCKDYNO_SKIP_DEMO") == "1", reason="demo disabled")
def test_demo_writes_recording_fit_and_report(tmp_path):
    # In this process: what it writes and says (a `shockdyno` process costs a second to start).
    res = cli("demo", "--out-dir", str(tmp_path), "--clicks", "3,15", "--cycles", "2")
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "demo.mcap").exists() and (tmp_path / "demo-fit.json").exists()
    index = tmp_path / "demo-report" / "index.html"
    html = index.read_text()
    assert "Table 4" in html
    assert "Enhancement" in res.stdout and str(index) in res.stdout
    rec = open_recording(tmp_path / "demo.mcap")
    assert len(rec.tests) == 6 and all(m.status == "complete" for m in rec.tests)
    # The demo's fit names its recording: a report of the two together is accepted.
    again = cli("report", str(tmp_path / "demo.mcap"), "--fit", str(tmp_path / "demo-fit.json"),
                "-o", str(tmp_path / "again"))  # fmt: skip
    assert again.returncode == 0, again.stderr
    # ... reading the model's forces the demo's fit saved beside it (fit/forces.py).
    assert (tmp_path / "demo-fit.forces.npz").exists() and "note:" not in again.stderr


def test_unreachable_rig_is_one_line_and_leaves_no_file(tmp_path):
    import socket

    with socket.socket() as s:  # a port that was free a moment ago: nothing listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    rig = tmp_path / "away.toml"
    rig.write_text(SIM_RIG.read_text().replace("port = 5020", f"port = {port}"))
    out = tmp_path / "never.mcap"
    res = cli("sweep", "--rig", str(rig), "--clicks", "1", "-o", str(out))
    assert res.returncode == 3  # a rig fault, not a usage error
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert "cannot connect" in res.stderr
    assert not out.exists()
