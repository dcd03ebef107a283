"""A full disk (issue 21.8): every writer names the file it could not write, in one line,
and nothing already on disk is lost. Needs a small tmpfs (root in the sandbox); skipped
where mounting is not permitted."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-m", "shockdyno.cli"]
EXAMPLE = REPO / "recordings" / "examples" / "example.mcap"


@pytest.fixture
def full(tmp_path: Path) -> Iterator[Path]:
    """A 64 KiB tmpfs with 4 KiB left."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)], capture_output=True
    )
    if done.returncode != 0:
        pytest.skip("cannot mount a small tmpfs here (not root, or not permitted)")
    try:
        (mnt / "fill").write_bytes(b"\0" * 60 * 1024)
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=120, cwd=REPO)


def test_a_full_disk_names_the_file_in_one_line(full: Path) -> None:
    cases = [
        (["fit", str(EXAMPLE), "--json", str(full / "fit.json")], "fit.json"),
        (
            [
                "sweep",
                "--rig",
                "rigs/sim.toml",
                "--start-sim",
                "--speed",
                "50",
                "--clicks",
                "0",
                "--freq",
                "1",
                "-o",
                str(full / "rec.mcap"),
            ],
            "rec.mcap",
        ),
        (
            [
                "import",
                str(REPO / "recordings/examples/csv/manifest.csv"),
                "-o",
                str(full / "imp.mcap"),
            ],
            "imp.mcap",
        ),
    ]
    for args, name in cases:
        done = _run(*args)
        err = done.stderr.strip().splitlines()
        assert done.returncode != 0, args
        assert err and "No space left on device" in err[-1] and name in err[-1], done.stderr
        assert "Traceback" not in done.stderr
    assert (full / "fill").stat().st_size == 60 * 1024  # what was there is untouched
