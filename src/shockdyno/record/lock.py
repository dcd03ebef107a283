"""One writer per recording: an exclusive lock held for as long as a recording is written.

The lock is `flock` on `.NAME.lock` beside the recording, so it dies with its process
(kill -9 included) and a crash never leaves a recording locked. The file holds the
holder's PID and command line, which a refused writer names. A second `sweep --resume`,
a `sweep --force` or an `import -o` onto a recording another process is writing is
refused in one line before it touches the file.
"""

from __future__ import annotations

import fcntl
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from shockdyno.errors import RecordingError


def lock_path(recording: Path) -> Path:
    return recording.with_name(f".{recording.name}.lock")


def _holder(path: Path) -> str:
    """ "process 1234 (shockdyno sweep ...)" from the lock file, as well as it can."""
    try:
        pid = path.read_text(encoding="utf-8").split("\n", 1)[0].strip()
    except OSError:
        return "another process"
    if not pid.isdigit():
        return "another process"
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
        cmd = " ".join(part.decode(errors="replace") for part in raw.split(b"\0") if part)
    except OSError:
        return f"process {pid}"
    return f"process {pid} ({cmd[:120]})" if cmd else f"process {pid}"


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
    try:
        try:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n{' '.join(sys.argv)}\n".encode())
        except OSError:
            pass  # a full disk: the lock holds all the same, only its holder goes unnamed
        yield
    finally:
        try:
            path.unlink(missing_ok=True)
        finally:
            os.close(fd)
