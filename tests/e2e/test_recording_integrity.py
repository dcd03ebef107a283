"""A recording is one file with one writer, `--force` replaces only a recording and only
once the new one has a complete test, a set holds one measurement, and a sweep that cannot
move is refused before the drive is enabled (issue 46.4, 46.8, 46.9, 46.1b)."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
from stop_helpers import Probe, reap, rig_file_for, spawn_sweep, wait_test_running

from shockdyno.cli import main
from shockdyno.record import RecordingWriter, open_recording
from shockdyno.record.layout import part_paths
from shockdyno.simrig.faults import Fault

REPO = Path(__file__).resolve().parents[2]
NOWHERE = REPO / "rigs" / "sim.toml"  # port 5020: no rig there; refusals come first
QUICK = ["--clicks", "0", "--freq", "2", "--cycles", "1", "--warmup-cycles", "0",
         "--no-gas-measure"]  # fmt: skip


def _one_line_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert err and "\n" not in err and "Traceback" not in err, err
    return err


def _recording(path: Path, damper: str, *, resume: bool = False, tests: int = 2) -> None:
    """A small recording written by the writer itself (no rig): `tests` complete tests."""
    from rec_helpers import block, meta

    with RecordingWriter(path, metadata={"damper_id": damper}, resume=resume) as w:
        for k in range(tests):
            w.begin_test(meta(k, k))
            w.write_samples(block(k * 10_000, 500))
            w.end_test(meta(k, k))


@pytest.fixture(autouse=True)
def _record_helpers(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(REPO / "tests" / "record"))


@pytest.mark.parametrize(
    ("name", "text"),
    [("other_rig.toml", NOWHERE.read_text()), ("table.csv", "a,b\n1,2\n"), ("fit.json", "{}\n")],
)
def test_force_never_replaces_another_kind_of_file(tmp_path, capsys, name, text) -> None:
    target = tmp_path / name
    target.write_text(text)
    code = main(["sweep", "--rig", str(NOWHERE), *QUICK, "-o", str(target), "--force"])
    assert code == 2
    assert "is not a recording; --force replaces only a recording" in _one_line_error(capsys)
    assert target.read_text() == text


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_an_output_that_is_no_file_is_refused_before_the_drive_is_enabled(
    sim_rig_factory, tmp_path, capsys, kind
) -> None:
    """`-o out.fifo --force` used to enable and centre the ram, then hang for ever on the
    FIFO's open with the drive enabled; `-o /dev/null --force` enabled and centred before
    failing. Both are refused first; the drive is never enabled."""
    sim = sim_rig_factory(speed=10.0)
    if kind == "fifo":
        target = tmp_path / "out.fifo"
        os.mkfifo(target)
    else:
        target = Path("/dev/null")
    probe = Probe(sim)
    try:
        before = probe.status()
        code = main(["sweep", "--rig", str(rig_file_for(sim, tmp_path)), *QUICK, "-o",
                     str(target), "--force"])  # fmt: skip
        after = probe.status()
    finally:
        probe.close()
    assert code == 2 and "not a regular file" in _one_line_error(capsys)
    assert before is not None and after is not None and not after.enabled
    assert len(sim.registers.control_log) == 0  # not a single command
    assert after.position_m == pytest.approx(before.position_m, abs=1e-5)


def test_force_keeps_the_old_recording_until_the_first_new_test_completes(
    sim_rig_factory, tmp_path, capsys
) -> None:
    """Issue 46.4: `--force` truncated the old recording as soon as the rig connected (4
    complete tests became 1 aborted one) and deleted an unrelated p.part2.mcap. Now the new
    recording is written beside the old one and takes its place when its first test is
    complete, removing the old set's own part files and no other file."""
    old = tmp_path / "p.mcap"
    _recording(old, "old damper")
    _recording(old, "old damper", resume=True, tests=1)  # p.part2.mcap, of the same set
    other = tmp_path / "p.part3.mcap"
    _recording(other, "another damper", tests=1)  # a separate recording, named like a part
    kept = {p.name: p.read_bytes() for p in (old, *part_paths(old))}
    assert set(kept) == {"p.mcap", "p.part2.mcap", "p.part3.mcap"}

    sim = sim_rig_factory(speed=4.0)
    rig = rig_file_for(sim, tmp_path)
    new = tmp_path / "p.new.mcap"
    proc = spawn_sweep(rig, old, "--force")
    try:
        wait_test_running(new, proc, limit_s=30)
        sim.inject(Fault("over_force", duration_s=2.0))  # the first new test is aborted
        out, _ = proc.communicate(timeout=60)
    finally:
        reap(proc)
    assert proc.returncode == 3
    assert {p.name: p.read_bytes() for p in (old, *part_paths(old))} == kept  # untouched
    assert [m.status for m in open_recording(new).tests] == ["aborted"]
    assert b"the first test did not complete" in out and b"p.new.mcap" in out

    code = main(["sweep", "--rig", str(rig), *QUICK, "-o", str(old), "--force"])
    assert code == 0, capsys.readouterr().err
    rec = open_recording(old)
    assert [m.status for m in rec.tests] == ["complete"] and rec.metadata["damper_id"] == ""
    assert not new.exists()  # the leftover of the aborted run was replaced, then moved
    assert not (tmp_path / "p.part2.mcap").exists()  # the old set's own part: gone
    assert other.read_bytes() == kept["p.part3.mcap"]  # another recording: kept
    assert rec.foreign and rec.foreign[0][0] == other  # and not read as a part of this one


def test_a_separate_recording_named_like_a_part_is_not_merged(tmp_path, capsys) -> None:
    """Issue 46.8: a sweep saved at p.part2.mcap with another damper was merged into
    p.mcap, shown as the first damper, with a repeated test index."""
    first = tmp_path / "p.mcap"
    _recording(first, "D-1")
    _recording(tmp_path / "p.part2.mcap", "D-2")
    rec = open_recording(first)
    assert [m.index for m in rec.tests] == [0, 1]
    assert rec.foreign and "set id" in rec.foreign[0][1]
    assert main(["info", str(first)]) == 0
    assert "NOT PART OF THIS RECORDING, not read: " in capsys.readouterr().out
    # Its own resumed part is read.
    _recording(first, "D-1", resume=True, tests=1)  # p.part3.mcap
    assert len(open_recording(first).tests) == 3


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ("rig", "another rig set-up (limits"),
        ("gas", "another plan (gas_pressure_pa"),
        ("freq", "another plan (frequencies_hz"),
    ],
)
def test_resume_refuses_another_rig_gas_pressure_or_plan(
    sim_rig_factory, tmp_path, capsys, change, words
) -> None:
    sim = sim_rig_factory(speed=4.0)
    rig = rig_file_for(sim, tmp_path)
    out = tmp_path / "set.mcap"
    plan = ["--clicks", "0,1", "--freq", "2", "--cycles", "2", "--warmup-cycles", "0",
            "--no-gas-measure", "--gas-pressure-bar", "12"]  # fmt: skip
    proc = spawn_sweep(rig, out, *plan)
    try:
        wait_test_running(out, proc, limit_s=30)
        proc.send_signal(signal.SIGINT)  # interrupted: something left to resume
        proc.communicate(timeout=60)
    finally:
        reap(proc)
    before = out.read_bytes()
    capsys.readouterr()
    if change == "rig":
        rig.write_text(rig.read_text().replace("velocity_m_s = 0.6", "velocity_m_s = 0.5"))
    elif change == "gas":
        plan[-1] = "10"
    else:
        plan[plan.index("--freq") + 1] = "2,3"
    code = main(["sweep", "--rig", str(rig), *plan, "-o", str(out), "--resume"])
    assert code == 2 and words in _one_line_error(capsys)
    assert out.read_bytes() == before and not part_paths(out)


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (("--freq", "1e-9"), "one cycle in 10 min"),
        (("--amplitude-mm", "0.000001"), "counts of the LVDT"),
        (("--temp-band-c", "95,99"), "temperature limit"),
    ],
)
def test_sweeps_that_cannot_move_are_refused_before_anything(tmp_path, capsys, flags, words):
    out = tmp_path / "never.mcap"
    code = main(["sweep", "--rig", str(NOWHERE), "--clicks", "0", *flags, "-o", str(out)])
    assert code == 2 and words in _one_line_error(capsys)
    assert not out.exists()


def test_a_temperature_band_that_is_not_two_numbers_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["sweep", "--rig", str(NOWHERE), "--temp-band-c", "nan,nan", "-o", "x.mcap"])
    assert exc.value.code == 2
    assert "LOW <= HIGH" in capsys.readouterr().err


def test_a_damaged_test_is_named_and_skipped_by_fit_and_export_and_redone_by_resume(
    sim_rig_factory, tmp_path, capsys
) -> None:
    """Issue 46.5: 32 bytes overwritten in the middle of a recording: `info` said complete,
    `fit` used the test without a word, `export` blamed the data, `--resume` counted it
    done. Now the test is `damaged` everywhere, and a resumed sweep runs it again."""
    sim = sim_rig_factory(speed=20.0)
    rig = rig_file_for(sim, tmp_path)
    out = tmp_path / "d.mcap"
    plan = ["--clicks", "0,10", "--freq", "2", "--cycles", "2", "--warmup-cycles", "0",
            "--no-gas-measure"]  # fmt: skip
    assert main(["sweep", "--rig", str(rig), *plan, "-o", str(out)]) == 0
    from rec_helpers import chunk_offsets

    data = bytearray(out.read_bytes())
    first = next(c for c in chunk_offsets(bytes(data)) if c[1] > 10_000)  # test 0's samples
    middle = first[0] + first[1] // 2
    data[middle : middle + 32] = b"\x00" * 32
    out.write_bytes(bytes(data))
    capsys.readouterr()

    assert main(["info", str(out)]) == 0
    info = capsys.readouterr().out
    assert "(1 complete, 0 aborted, 1 damaged)" in info and "DAMAGED: " in info

    fit = tmp_path / "fit.json"
    assert main(["fit", str(out), "--json", str(fit)]) == 0
    err = capsys.readouterr().err
    assert "1 damaged tests left out (test 0: " in err
    assert [t["clicks"] for t in __import__("json").loads(fit.read_text())["tests"]] == [10]

    assert main(["export", str(out), "--csv", str(tmp_path / "csv")]) == 0
    err = capsys.readouterr().err
    assert "damaged tests left out" in err
    assert (tmp_path / "csv" / "manifest.csv").read_text().count("\n") == 2  # header + test 1

    assert main(["sweep", "--rig", str(rig), *plan, "-o", str(out), "--resume"]) == 0
    assert "1 tests done, 1 to go" in " ".join(capsys.readouterr().out.split())
    assert open_recording(out).completed_keys() == {(0, 0, 2.0), (10, 0, 2.0)}
