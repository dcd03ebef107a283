"""A recording has one writer (issue 21.3): a second sweep, `--resume` or `--force` on a
recording another process is writing is refused, naming that process; nothing of the
first is lost."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from inprocess import cli
from shockdyno.errors import RecordingError
from shockdyno.record import open_recording
from shockdyno.record.lock import lock_path

REPO = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-m", "shockdyno.cli"]
SWEEP = [*CLI, "sweep", "--rig", str(REPO / "rigs" / "sim.toml"), "--start-sim"]


def _wait_for(path: Path, timeout_s: float = 30.0) -> None:
    end = time.monotonic() + timeout_s
    while not path.exists():
        assert time.monotonic() < end, f"{path} never appeared"
        time.sleep(0.05)


def _until_a_test_is_done(rec: Path, first: subprocess.Popen[bytes]) -> None:
    """The refused writers take a fraction of a second each: the first is stopped only
    once it has finished a test, so that what it wrote can be checked."""
    end = time.monotonic() + 60
    while True:
        assert first.poll() is None and time.monotonic() < end, "the first writer did no test"
        try:
            if any(t.status == "complete" for t in open_recording(rec).tests):
                return
        except RecordingError:  # read between two writes; try again
            pass
        time.sleep(0.1)


def _first_writer(rec: Path) -> subprocess.Popen[bytes]:
    """A long sweep writing `rec` (22 tests at 4x): the one every other writer meets."""
    return subprocess.Popen(
        [*SWEEP, "--speed", "4", "--clicks", "0-21", "--freq", "1", "-o", str(rec)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def _second(out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    """The second writer in this process (the first is another process: the lock is
    between processes), refused before it starts a rig."""
    args = [*SWEEP[len(CLI) :], "--speed", "50", "--clicks", "0", "--freq", "1", "-o", str(out)]
    return cli(*args, *extra)


def test_a_second_writer_is_refused_by_name_and_the_first_goes_on(tmp_path: Path) -> None:
    rec = tmp_path / "one.mcap"
    first = _first_writer(rec)
    try:
        _wait_for(rec)  # the writer has the lock before it creates the file
        assert lock_path(rec).exists()
        for extra in (["--resume"], ["--force"], []):
            second = _second(rec, *extra)
            assert second.returncode != 0, extra
            err = second.stderr.strip()
            assert err.count("\n") == 0, err
            assert f"being written by process {first.pid}" in err and "sweep" in err, err
            assert rec.exists() and first.poll() is None  # the first still runs, its file kept
        # `import -o` onto it is refused the same way.
        csv = REPO / "recordings" / "examples" / "csv" / "manifest.csv"
        imp = cli("import", str(csv), "-o", str(rec), "--force")
        assert imp.returncode != 0 and f"process {first.pid}" in imp.stderr
        _until_a_test_is_done(rec, first)
    finally:
        first.send_signal(signal.SIGINT)
        first.wait(timeout=60)
    # The first writer's tests are all there, and its lock is gone with it.
    tests = open_recording(rec).require_recording().tests
    assert tests and all(t.clicks == i for i, t in enumerate(tests[:-1]))
    assert not lock_path(rec).exists()


def test_a_link_to_a_recording_being_written_is_the_same_recording(tmp_path: Path) -> None:
    """Issue 46.3: the lock was keyed on the name, so a sweep through a symlink or a hard
    link to the recording another sweep was writing replaced its file (both exited 0, the
    first's three tests were gone). The file itself is locked now."""
    rec = tmp_path / "w.mcap"
    first = _first_writer(rec)
    try:
        _wait_for(rec)
        soft, hard = tmp_path / "wlink.mcap", tmp_path / "whard.mcap"
        soft.symlink_to(rec.name)
        os.link(rec, hard)
        for link, extra in ((soft, "--force"), (hard, "--force"), (hard, "--resume")):
            second = _second(link, extra)
            err = second.stderr.strip()
            assert second.returncode != 0 and err.count("\n") == 0, (link, extra, err)
            assert f"being written by process {first.pid}" in err, err
            assert first.poll() is None
        assert not (tmp_path / "wlink.new.mcap").exists()
        assert not (tmp_path / "whard.new.mcap").exists()
        _until_a_test_is_done(rec, first)
    finally:
        first.send_signal(signal.SIGINT)
        first.wait(timeout=60)
    tests = open_recording(rec).require_recording().tests
    assert tests and all(t.clicks == i for i, t in enumerate(tests[:-1]))  # the first's, all
    assert hard.samefile(rec)  # nothing replaced it
