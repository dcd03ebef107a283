"""Outputs that appear whole or not at all: write beside the target, then rename."""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from shockdyno.errors import RecordingError


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextmanager
def atomic_file(target: Path, force: bool) -> Iterator[Path]:
    """Yield a temporary path beside `target`; on success it replaces `target`."""
    if target.exists() and not force:
        raise RecordingError(f"{target} exists (use --force to overwrite it)")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
        os.close(fd)
        os.chmod(tmp_name, 0o666 & ~_umask())  # mkstemp makes it private; outputs are not
    except OSError as exc:
        raise RecordingError(f"cannot write {target}: {exc.strerror}") from exc
    tmp = Path(tmp_name)
    try:
        yield tmp
        if target.exists() and not force:  # appeared while we worked
            raise RecordingError(f"{target} exists (use --force to overwrite it)")
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)


@contextmanager
def atomic_dir(target: Path, force: bool) -> Iterator[Path]:
    """Yield a temporary directory; on success its files move into `target`.

    Without force, `target` must not exist or be empty. With force, files of the same name in
    `target` are replaced and other files are left alone.
    """
    if target.exists() and not target.is_dir():
        raise RecordingError(f"{target} exists and is not a directory")
    if target.is_dir() and any(target.iterdir()) and not force:
        raise RecordingError(f"{target} is not empty (use --force to write into it)")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
        os.chmod(tmp, 0o777 & ~_umask())
    except OSError as exc:
        raise RecordingError(f"cannot write {target}: {exc.strerror}") from exc
    try:
        yield tmp
        if not target.exists():
            os.replace(tmp, target)
        else:
            for f in sorted(tmp.iterdir()):
                os.replace(f, target / f.name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_text_atomic(target: Path, text: str) -> None:
    """Replace `target` with `text` (UTF-8) only once the new content is complete."""
    write_bytes_atomic(target, text.encode("utf-8"))


def write_bytes_atomic(target: Path, data: bytes) -> None:
    """Replace `target` with `data` only once the new content is complete."""
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes it private; outputs are not
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


STAGED = ".partial-"  # .NAME.partial-PID-xxxx: a folder being written beside NAME
REPLACED = ".replaced-"  # .NAME.replaced-PID-xxxx: NAME's previous folder, while swapping


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: alive
        return True
    return True


def _owner(folder: Path, marker: str) -> int | None:
    """The process id in a staged or replaced folder's name, None if it has none."""
    tail = folder.name.rpartition(marker)[2]
    head = tail.partition("-")[0]
    return int(head) if head.isdigit() else None


def _tidy(target: Path) -> None:
    """What a killed writer of `target` left beside it: its staged folder is removed; a
    previous folder it had moved aside, with nothing put in its place, is moved back."""
    for marker in (STAGED, REPLACED):
        for left in target.parent.glob(f".{target.name}{marker}*"):
            pid = _owner(left, marker)
            if pid is None or pid == os.getpid() or _alive(pid):
                continue
            if marker == REPLACED and not target.exists():
                os.rename(left, target)
            else:
                shutil.rmtree(left, ignore_errors=True)


def _merge_into(old: Path, new: Path) -> None:
    """Move every entry of `old` that `new` does not have into `new` (folders merged
    entry by entry): a user's own files in a report folder outlive the report."""
    for entry in sorted(old.iterdir()):
        there = new / entry.name
        if not there.exists():
            os.rename(entry, there)
        elif entry.is_dir() and there.is_dir() and not there.is_symlink():
            _merge_into(entry, there)


@contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C, SIGTERM or SIGHUP during a few renames waits until they are done (main
    thread only: elsewhere Python cannot take signals at all)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    kinds = [signal.SIGINT, signal.SIGTERM, *([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])]
    previous = {s: signal.signal(s, lambda n, _f: got.append(n)) for s in kinds}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        for n in got[:1]:
            signal.raise_signal(n)


class Stopped(KeyboardInterrupt):
    """SIGTERM or SIGHUP while a folder is staged: unwinds like Ctrl-C, so the staged
    folder is removed (the command line reports it as stopped by that signal)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


@contextmanager
def _stops_unwind() -> Iterator[None]:
    """SIGTERM and SIGHUP raise Stopped instead of ending the process on the spot, where
    no handler of their own is installed (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum: int, _frame: object) -> None:
        raise Stopped(signum)

    kinds = [signal.SIGTERM, *([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])]
    previous = {s: signal.getsignal(s) for s in kinds}
    for s, handler in previous.items():
        if handler == signal.SIG_DFL:
            signal.signal(s, stop)
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


@contextmanager
def staged_dir(target: Path) -> Iterator[Path]:
    """Yield an empty folder beside `target` to write a whole output folder into (a report
    page and its figures); once the block ends it becomes `target` in one step, and until
    then `target` is as it was. Any failure, Ctrl-C, SIGTERM and SIGHUP included, removes
    the staged folder.

    `target` new: the staged folder is renamed to it. `target` there (a report replaced
    with --force, a folder of the user's): the two are swapped by renames, then the old
    folder's entries the new one lacks (the user's own files) are moved in, as a report
    written in place used to leave them, and the old folder is removed; signals wait for
    those renames. A writer killed outright leaves a hidden `.NAME.partial-PID-*` folder,
    which the next writer of `target` removes."""
    target = Path(target)
    if target.exists() and not target.is_dir():
        raise RecordingError(f"{target} exists and is not a directory")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        _tidy(target)
        staged = Path(
            tempfile.mkdtemp(prefix=f".{target.name}{STAGED}{os.getpid()}-", dir=target.parent)
        )
        os.chmod(staged, 0o777 & ~_umask())  # mkdtemp makes it private; outputs are not
    except OSError as exc:
        raise RecordingError(f"cannot write {target}: {exc.strerror}") from exc
    try:
        with _stops_unwind():
            yield staged
        with _signals_held():
            if not target.exists():
                os.rename(staged, target)
                return
            old = staged.with_name(staged.name.replace(STAGED, REPLACED, 1))
            os.rename(target, old)
            os.rename(staged, target)
            _merge_into(old, target)
            shutil.rmtree(old, ignore_errors=True)
    finally:
        if staged.exists():
            shutil.rmtree(staged, ignore_errors=True)
