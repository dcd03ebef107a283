"""The output-path policy every command shares.

No command overwrites an existing file without `--force`, none ever writes over one of its
own inputs (with or without `--force`), and `-` means standard output. Commands call
`check_output` before doing any work, so a refused path costs nothing and writes nothing,
then `write_output` once the result is complete.

`--force` replaces what the command itself writes, never another kind of file: a
recording only by a recording (`check_recording_output`), a report folder only when a
shockdyno page is its index.html, and nothing replaces a FIFO or a device (which would
block or swallow the output) or, but a recording, an MCAP recording.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Iterable
from pathlib import Path

from shockdyno.atomic import write_text_atomic
from shockdyno.errors import ConfigError
from shockdyno.result_files import starts_as_mcap

STDOUT = "-"
# How a page this project wrote says so (report/html.py); older pages carry the print
# script's function name instead.
GENERATOR_MARK = '<meta name="generator" content="shockdyno">'
OLD_PAGE_MARK = "shockdynoEager"


def is_stdout(path: str | os.PathLike[str] | None) -> bool:
    return path is not None and os.fspath(path) == STDOUT


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.samefile(b)
    except OSError:
        return a.resolve() == b.resolve()


def refuse_inputs(
    out: Path, inputs: Iterable[str | os.PathLike[str]], flag: str = "--json"
) -> None:
    """An output that is one of the command's inputs (also through a link) is refused,
    `--force` or not."""
    for source in inputs:
        if _same_file(out, Path(source)):
            raise ConfigError(f"{flag} {out} is an input of this command; refusing to overwrite it")


def check_output(
    path: str | os.PathLike[str],
    *,
    force: bool,
    inputs: Iterable[str | os.PathLike[str]] = (),
    flag: str = "--json",
) -> Path | None:
    """Refuse an output path before any work is done; None means standard output.

    Refused, as one-line ConfigErrors: one of `inputs` (also through a link), an existing
    file without `force`, a directory, a missing parent directory, a directory this process
    cannot create files in (found by creating and removing a probe file).
    """
    if is_stdout(path):
        return None
    out = Path(path)
    refuse_inputs(out, inputs, flag)
    if out.is_dir():
        raise ConfigError(f"{flag} {out} is a directory")
    if out.exists() and not force:
        raise ConfigError(f"{flag} {out} exists (use --force to overwrite it)")
    if out.exists():
        _refuse_other_kind(out, flag, recording=False)
    _check_parent(out, flag)
    return out


def _refuse_other_kind(out: Path, flag: str, *, recording: bool) -> None:
    """--force replaces a file of the kind the command writes, nothing else."""
    if not out.is_file():
        raise ConfigError(f"{flag} {out} is not a regular file (a FIFO or a device); refused")
    try:
        mcap = out.stat().st_size > 0 and starts_as_mcap(out)
    except OSError as exc:
        raise ConfigError(f"{flag} {out}: cannot read it ({exc.strerror})") from None
    if recording and out.stat().st_size > 0 and not mcap:
        raise ConfigError(
            f"{flag} {out} exists and is not a recording; --force replaces only a recording "
            "(refused, whatever the flags: choose another name)"
        )
    if not recording and mcap:
        raise ConfigError(
            f"{flag} {out} is an MCAP recording; --force does not replace a recording with "
            "another kind of file (choose another name)"
        )


def check_recording_output(path: Path, *, force: bool, flag: str = "-o") -> None:
    """A recording's output before anything is done: not a folder, a FIFO or a device, an
    existing file only with `force` and only when it is a recording, in a folder that
    takes new files."""
    if path.is_dir():
        raise ConfigError(f"{flag} {path} is a directory")
    if path.exists() or path.is_symlink():
        if not force:
            raise ConfigError(f"{flag} {path} exists (use --force to replace the recording)")
        _refuse_other_kind(path, flag, recording=True)
    _check_parent(path, flag)


def _check_parent(out: Path, flag: str) -> None:
    """The folder must exist and take new files (found by creating and removing one)."""
    parent = out.parent
    if not parent.is_dir():
        raise ConfigError(f"{flag}: directory {parent} does not exist")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".probe", dir=parent)
    except OSError as exc:
        raise ConfigError(f"{flag}: cannot create files in {parent} ({exc.strerror})") from None
    os.close(fd)
    os.unlink(probe)


REPORT_FILES = ("index.html", "click_chart.csv", "click_chart_reference.csv")


def check_report_dir(
    out: Path, inputs: Iterable[str | os.PathLike[str]], force: bool, flag: str = "--report"
) -> None:
    """Refuse a report DIR before any work: a file, an existing report (DIR/index.html)
    without `force`, one whose files would overwrite an input, or a DIR that cannot be
    created."""
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{flag} {out}: is a file, not a directory")
    index = out / "index.html"
    if index.is_file() and index.stat().st_size > 0 and not force:
        raise ConfigError(f"{flag}: {index} exists (use --force to replace it)")
    if index.exists() and not _our_page(index):
        raise ConfigError(
            f"{flag}: {index} is not a page shockdyno wrote; --force replaces only a report "
            "this tool wrote (choose another folder)"
        )
    own = {(out / name).resolve() for name in REPORT_FILES}
    for source in inputs:
        path = Path(source)
        drawn = path.suffix == ".png" and path.resolve().parent == out.resolve()
        if path.resolve() in own or drawn:
            raise ConfigError(f"{flag}: the report would overwrite its input {path}")
    if out.is_dir() and not index.is_file() and not force:
        # not a report (yet), but holding files a report would write over: someone's own
        clash = sorted(
            p.name
            for p in out.iterdir()
            if p.is_file() and (p.name in REPORT_FILES or p.suffix in (".png", ".csv"))
        )
        if clash:
            raise ConfigError(
                f"{flag}: {out} holds files a report would write over ({', '.join(clash[:3])}"
                f"{', ...' if len(clash) > 3 else ''}); use --force or another directory"
            )
    base = out
    while not base.exists():  # the nearest existing ancestor must take new files
        base = base.parent
    if not os.access(base, os.W_OK | os.X_OK):
        raise ConfigError(f"{flag}: cannot create files in {base}")


def _our_page(index: Path) -> bool:
    """Whether index.html is a page this project wrote (an empty one is nobody's)."""
    if not index.is_file():
        return False
    try:
        with index.open("rb") as fh:
            head = fh.read(1 << 16).decode("utf-8", errors="replace")
    except OSError:
        return False
    return not head or GENERATOR_MARK in head or OLD_PAGE_MARK in head


def write_output(
    path: str | os.PathLike[str],
    text: str,
    *,
    force: bool,
    inputs: Iterable[str | os.PathLike[str]] = (),
    flag: str = "--json",
) -> Path | None:
    """Write `text` to standard output (`-`) or, whole or not at all, to the checked path."""
    out = check_output(path, force=force, inputs=inputs, flag=flag)
    if out is None:
        sys.stdout.write(text)
        sys.stdout.flush()
        return None
    try:
        write_text_atomic(out, text)
    except OSError as exc:
        raise ConfigError(f"{flag}: cannot write {out} ({exc.strerror})") from None
    return out
