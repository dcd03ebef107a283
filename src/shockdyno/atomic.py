"""Outputs that appear whole or not at all: write beside the target, then rename."""

from __future__ import annotations

import os
import shutil
import tempfile
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
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes it private; outputs are not
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
