"""A recording's identity: the SHA-256 of its bytes (every file of the set, in order).

Fit, diagnosis and ride results carry it, so a result given with another recording is
recognised instead of being shown as that recording's (docs/fit.md, `info.recording`).
"""

from __future__ import annotations

import argparse
import hashlib
from pathlib import Path

from shockdyno.errors import ConfigError, RecordingError
from shockdyno.record.layout import set_paths

CHUNK = 1 << 20


def recording_sha256(path: Path) -> str:
    """The hex SHA-256 of a recording's bytes, every file of its set in order; RecordingError
    when there is none or it cannot be read."""
    digest = hashlib.sha256()
    paths = set_paths(Path(path))
    if not paths:
        raise RecordingError(f"no such recording: {path}")
    for p in paths:
        try:
            with p.open("rb") as fh:
                while block := fh.read(CHUNK):
                    digest.update(block)
        except OSError as exc:
            raise RecordingError(f"cannot read {p} ({exc.strerror})") from None
    return digest.hexdigest()


def recording_info(path: Path) -> dict[str, str]:
    """What a result stores of the recording it was made from."""
    return {"file": Path(path).name, "sha256": recording_sha256(path)}


ALLOW_FLAG = "--allow-other-recording"


def provenance(stored: str | None, actual: str, what: str, flag: str, allow: bool) -> str:
    """One line for the page on where a result came from. A result of another recording,
    or one that does not say which recording it was made from, is refused unless `allow`
    (ALLOW_FLAG, explicitly: --force replaces outputs and waives no input check), and then
    the line says so (the caller prints it on the terminal too)."""
    if stored == actual:
        return f"made from this recording (sha256 {actual[:12]})"
    if stored is None:
        line = f"{what} does not say which recording it was made from (no info.recording)"
    else:
        line = (
            f"{what} was made from another recording (sha256 {stored[:12]}, this one {actual[:12]})"
        )
    if not allow:
        raise ConfigError(f"{flag}: {line}; use {ALLOW_FLAG} to show it anyway")
    return f"NOT CHECKED AGAINST THIS RECORDING: {line}; shown because of {ALLOW_FLAG}"


def add_allow_argument(p: argparse._ActionsContainer, what: str) -> None:
    """The one flag that accepts a result of another recording, in every command."""
    p.add_argument(
        ALLOW_FLAG,
        action="store_true",
        help=f"accept {what} made from another recording, or one that does not say which "
        "(refused by default; the terminal and the output say so)",
    )
