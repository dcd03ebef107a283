"""The output-path policy every command shares.

No command overwrites an existing file without `--force`, none ever writes over one of its
own inputs (with or without `--force`), and `-` means standard output. Commands call
`check_output` before doing any work, so a refused path costs nothing and writes nothing,
then `write_output` once the result is complete.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Iterable
from pathlib import Path

from shockdyno.errors import ConfigError

STDOUT = "-"


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
    parent = out.parent
    if not parent.is_dir():
        raise ConfigError(f"{flag}: directory {parent} does not exist")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".probe", dir=parent)
    except OSError as exc:
        raise ConfigError(f"{flag}: cannot create files in {parent} ({exc.strerror})") from None
    os.close(fd)
    os.unlink(probe)
    return out


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
    from shockdyno.atomic import write_text_atomic

    try:
        write_text_atomic(out, text)
    except OSError as exc:
        raise ConfigError(f"{flag}: cannot write {out} ({exc.strerror})") from None
    return out
