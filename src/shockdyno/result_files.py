"""Reading a result file (FIT.json, DIAG.json, RIDE.json) given on the command line.

A user hands `--fit`, `--diagnose` or `--ride` whatever file is at hand: a recording, a
CSV, the other kind of result. Each gets one short line naming what the file is and what
was expected, never the file's bytes (a recording's UnicodeDecodeError once printed an
11.9 MB "line"), and a result of the wrong kind is refused rather than read as empty.
No I/O beyond reading the one file; no project imports, so any layer may use it.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from shockdyno.errors import ConfigError

MCAP_MAGIC = b"\x89MCAP"


@dataclass(frozen=True)
class RecordingRef:
    """What a result was made from: FIT.json's and DIAG.json's `info.recording`, a
    RIDE.json's `fit_recording` (`record.identity.recording_info`)."""

    file: str
    sha256: str


def starts_as_mcap(path: Path) -> bool:
    """Whether the file starts as every MCAP file does (OSError propagates: each caller
    says in its own words what a missing or unreadable file means to it)."""
    with path.open("rb") as fh:
        return fh.read(len(MCAP_MAGIC)) == MCAP_MAGIC


# What each kind of result holds at its top level (all of them, to be that kind).
KINDS: dict[str, tuple[str, tuple[str, ...]]] = {
    "fit": ("a fit result (FIT.json, from shockdyno fit)", ("globals", "clicks")),
    "diagnosis": ("a diagnosis (DIAG.json, from shockdyno diagnose)", ("mismatch", "findings")),
    "ride": ("a ride study (RIDE.json, from shockdyno ride)", ("rms", "flags")),
}


def kind_of(doc: object) -> str | None:
    """Which result a parsed JSON document is, if any."""
    if not isinstance(doc, dict):
        return None
    for kind, (_, keys) in KINDS.items():
        if all(k in doc for k in keys):
            return kind
    return None


def what_bytes_are(head: bytes) -> str:
    if head.startswith(MCAP_MAGIC):
        return "an MCAP recording"
    if head[:4] == b"PAR1":
        return "a Parquet table"
    if b"\x00" in head:
        return "a binary file"
    return "not JSON"


def special_file(path: Path) -> bool:
    """A FIFO or a device: reading it would block (a FIFO) or never end (/dev/zero)."""
    return path.exists() and not path.is_dir() and not path.is_file()


def read_result(path: str | Path, flag: str, expected: str) -> dict[str, Any]:  # json.loads's
    """The JSON document at `path`, checked to be the `expected` kind of result; else a
    one-line ConfigError naming `flag`, the file, what it is and what was expected."""
    p = Path(path)
    want = KINDS[expected][0]
    if special_file(p):
        raise ConfigError(f"{flag}: {p} is not a regular file; expected {want}")
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{flag}: {p} not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{flag}: {p} is a folder; expected {want}") from None
    except OSError as exc:
        raise ConfigError(f"{flag}: cannot read {p}: {exc.strerror or exc}") from None
    try:
        doc = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise ConfigError(f"{flag}: {p} is {what_bytes_are(raw[:64])}; expected {want}") from None
    except json.JSONDecodeError as exc:
        what = what_bytes_are(raw[:64])
        where = f" ({exc.msg}, line {exc.lineno})" if what == "not JSON" else ""
        raise ConfigError(f"{flag}: {p} is {what}{where}; expected {want}") from None
    except RecursionError:
        raise ConfigError(f"{flag}: {p} is nested too deeply; expected {want}") from None
    except ValueError as exc:  # an integer of more digits than Python converts (4300)
        said = str(exc).split(";")[0]
        raise ConfigError(f"{flag}: {p} holds a value no result holds ({said})") from None
    got = kind_of(doc)
    if got != expected:
        what = KINDS[got][0] if got is not None else "JSON of another kind"
        raise ConfigError(f"{flag}: {p} is {what}; expected {want}")
    assert isinstance(doc, dict)  # kind_of said so
    return doc


def not_a_recording(path: Path) -> str | None:
    """What a file given where a recording belongs is, when it starts as something else:
    "a fit result (FIT.json, from shockdyno fit)", "a CSV file", ...; None for a file that
    starts as MCAP or cannot be read (the recording's reader says what is wrong)."""
    try:
        with path.open("rb") as fh:
            head = fh.read(64)
    except OSError:
        return None
    if len(head) < len(MCAP_MAGIC) or head.startswith(MCAP_MAGIC) or special_file(path):
        return None
    if head.lstrip()[:1] in (b"{", b"["):
        try:
            kind = kind_of(json.loads(path.read_bytes().decode("utf-8")))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            return None
        return KINDS[kind][0] if kind is not None else "a JSON file"
    if head.startswith(b"PAR1"):
        return "a Parquet table"
    first = head.split(b"\n")[0].strip().decode("utf-8", errors="replace")
    if re.fullmatch(r'[\w."\-]+(,[\w."\-]*)+', first):  # a header: file,clicks,...
        return "a CSV file (a manifest CSV becomes a recording with shockdyno import)"
    return None
