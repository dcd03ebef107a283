"""The report folder appears whole or not at all (issue 47.6): `shockdyno report` stopped
half-way (Ctrl-C, SIGTERM, a kill) leaves no PNG or CSV behind, an earlier report
untouched, and a re-run that is not refused."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from inprocess import cli
from shockdyno.atomic import staged_dir

REPO = Path(__file__).resolve().parents[2]


# The CLI with Ctrl-C's handler set: a suite started where SIGINT is ignored (a background
# job of a shell without job control) passes that on, and Python then installs none.
INTERRUPTIBLE = [
    sys.executable,
    "-c",
    "import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
    "from shockdyno.cli import main; sys.exit(main())",
]


def _files(folder: Path) -> dict[str, bytes]:
    files = [p for p in folder.rglob("*") if p.is_file()]
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in files}


def _stop_midway(args: list[str], out: Path, signum: int) -> subprocess.CompletedProcess[str]:
    """Run `report` and send `signum` once its staged folder holds a figure."""
    proc = subprocess.Popen([*INTERRUPTIBLE, *args], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    deadline = time.monotonic() + 90
    try:
        while not any(out.parent.glob(f".{out.name}.partial-*/*.png")):
            assert proc.poll() is None, f"the report ended before it was stopped: {proc.stderr}"
            assert time.monotonic() < deadline, "no figure was drawn in 90 s"
            time.sleep(0.02)
        proc.send_signal(signum)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)


def _hidden(out: Path) -> list[str]:
    return sorted(p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}."))


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_report_stopped_half_way_leaves_nothing_and_the_rerun_is_not_refused(
    recording: Path, tmp_path: Path, signum: int
) -> None:
    out = tmp_path / "page"
    done = _stop_midway(["report", str(recording), "-o", str(out)], out, signum)
    assert done.returncode == 128 + signum  # 130 "interrupted", 143 "stopped by SIGTERM"
    assert not out.exists() and _hidden(out) == []  # no PNG, no CSV, no staged folder
    again = cli("report", str(recording), "-o", str(out))
    assert again.returncode == 0, again.stderr
    assert (out / "index.html").is_file() and (out / "click_chart.csv").is_file()
    assert _hidden(out) == []


def test_a_replacing_report_stopped_half_way_leaves_the_earlier_one_as_it_was(
    recording: Path, small_recording: Path, tmp_path: Path
) -> None:
    out = tmp_path / "page"
    first = cli("report", str(small_recording), "-o", str(out))
    assert first.returncode == 0, first.stderr
    (out / "notes.txt").write_text("the operator's own notes\n")
    before = _files(out)
    done = _stop_midway(["report", str(recording), "-o", str(out), "--force"], out, signal.SIGINT)
    assert done.returncode == 130 and "interrupted" in done.stderr
    assert _files(out) == before and _hidden(out) == []


def test_a_finished_replacement_keeps_the_users_own_files(
    small_recording: Path, tmp_path: Path
) -> None:
    out = tmp_path / "page"
    out.mkdir()
    (out / "notes.txt").write_text("the operator's own notes\n")
    (out / "old").mkdir()
    (out / "old" / "photo.jpg").write_bytes(b"\xff\xd8 a photo")
    args = ["report", str(small_recording), "-o", str(out), "--force"]
    done = cli(*args)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"report: {out / 'index.html'}"  # the final path, not the staged
    files = _files(out)
    assert files["notes.txt"] == b"the operator's own notes\n"
    assert files["old/photo.jpg"] == b"\xff\xd8 a photo"
    assert "index.html" in files and any(name.endswith(".png") for name in files)
    assert _hidden(out) == []


def test_a_killed_writers_staged_folder_is_removed_by_the_next(tmp_path: Path) -> None:
    # A writer killed outright (SIGKILL: no clean-up runs) leaves its hidden staged folder,
    # and one that died between its two renames leaves the old folder moved aside.
    target = tmp_path / "page"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    pid = int(dead.stdout)  # a process that has ended
    staged = tmp_path / f".page.partial-{pid}-abcd"
    staged.mkdir()
    (staged / "peaks.png").write_bytes(b"half")
    aside = tmp_path / f".page.replaced-{pid}-abcd"
    aside.mkdir()
    (aside / "index.html").write_text("the earlier page")
    with staged_dir(target) as folder:
        assert not staged.exists()  # removed before anything is written
        assert (target / "index.html").read_text() == "the earlier page"  # moved back
        (folder / "index.html").write_text("the new page")
    assert (target / "index.html").read_text() == "the new page"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["page"]


def test_a_failure_inside_leaves_the_target_as_it_was(tmp_path: Path) -> None:
    target = tmp_path / "page"
    target.mkdir()
    (target / "index.html").write_text("the earlier page")
    with pytest.raises(RuntimeError), staged_dir(target) as folder:
        (folder / "index.html").write_text("half a page")
        raise RuntimeError("a figure failed")
    assert (target / "index.html").read_text() == "the earlier page"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["page"]
