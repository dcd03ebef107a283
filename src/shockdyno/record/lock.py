"""One writer per recording: an exclusive lock held for as long as a recording is written.

Two locks, both `flock`, so they die with their process (kill -9 included) and a crash
never leaves a recording locked:

- the name: `.NAME.lock` beside the recording's real path (symlinks resolved), holding the
  holder's PID and command line, which a refused writer names;
- the file itself: every existing file of the set is locked by its inode, and a writer
  locks the file it creates (record/writer.py). A hard link or a symlink is another name
  for the same inode, so a second sweep through it is refused too (through a link it
  would replace the file another sweep is writing).

A second `sweep --resume`, a `sweep --force` or an `import -o` onto a recording another
process is writing is refused in one line before it touches the file.
"""

from __future__ import annotations

import fcntl
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from shockdyno.errors import RecordingError
from shockdyno.record.reader import set_members


def lock_path(recording: Path) -> Path:
    """The lock file beside a recording (`.NAME.lock`, the symlink resolved): held while a
    command writes it."""
    real = Path(os.path.realpath(recording))
    return real.with_name(f".{real.name}.lock")


def _inode_holder(st: os.stat_result) -> str:
    """ "process 1234 (shockdyno sweep ...)" holding a lock on this inode (/proc/locks)."""
    try:
        lines = Path("/proc/locks").read_text().splitlines()
    except OSError:
        return "another process"
    want = (os.major(st.st_dev), os.minor(st.st_dev), st.st_ino)
    for line in lines:
        fields = line.split()
        if len(fields) < 6 or fields[1] != "FLOCK" or fields[0].endswith("->"):
            continue
        try:
            major, minor, inode = fields[5].split(":")
            found = (int(major, 16), int(minor, 16), int(inode))
        except ValueError:
            continue
        if found == want and fields[4].isdigit() and int(fields[4]) != os.getpid():
            return _process(fields[4])
    return "another process"


def _process(pid: str) -> str:
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
        cmd = " ".join(part.decode(errors="replace") for part in raw.split(b"\0") if part)
    except OSError:
        return f"process {pid}"
    return f"process {pid} ({cmd[:120]})" if cmd else f"process {pid}"


def lock_file(path: Path, fd: int, recording: Path) -> None:
    """Lock an open file of a recording by its inode, or raise RecordingError naming the
    process that holds it (under whichever name it opened it)."""
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _inode_holder(os.fstat(fd))
        raise RecordingError(
            f"{recording} is being written by {holder} (the file {path}, also under another "
            "name); refusing to write it too"
        ) from None


def _holder(path: Path) -> str:
    """ "process 1234 (shockdyno sweep ...)" from the lock file, as well as it can."""
    try:
        pid = path.read_text(encoding="utf-8").split("\n", 1)[0].strip()
    except OSError:
        return "another process"
    if not pid.isdigit():
        return "another process"
    return _process(pid)


@contextmanager
def recording_lock(recording: Path) -> Iterator[None]:
    """Hold the recording's write lock, or raise RecordingError naming its holder."""
    path = lock_path(recording)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecordingError(f"{recording}: cannot create {path.parent} ({exc.strerror})") from None
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise RecordingError(
                f"-o {recording}: cannot create files in {path.parent} ({exc.strerror})"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise RecordingError(
                f"{recording} is being written by {_holder(path)}; refusing to write it too"
            ) from None
        # The holder before us may have removed the file between our open and our lock:
        # then we hold a lock on a name no one else sees. Try again on the current file.
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    held: list[int] = []
    try:
        try:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n{' '.join(sys.argv)}\n".encode())
        except OSError:
            pass  # a full disk: the lock holds all the same, only its holder goes unnamed
        for member in set_members(Path(os.path.realpath(recording))):
            try:
                held.append(os.open(member, os.O_RDONLY | os.O_NONBLOCK))
            except OSError:
                continue  # gone meanwhile, or unreadable: the writer's own checks say so
            lock_file(member, held[-1], recording)
        yield
    finally:
        for other in held:
            os.close(other)
        try:
            path.unlink(missing_ok=True)
        finally:
            os.close(fd)
