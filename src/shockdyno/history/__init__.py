"""Each damper's history: every recording's identity and results, in an embedded database.

`fit`, `diagnose` and `batch fit|diagnose` add what they made; `shockdyno history DAMPER`
shows how the damper changed (docs/history.md). The database is one SQLite file in the
project's data folder, `recordings/history.sqlite` under the working directory (where the
shop's recordings live; `SHOCKDYNO_HISTORY` or `--history PATH` names another); no server.

Why SQLite rather than DuckDB: it is in Python's standard library (nothing to pin or
install), its file format has been stable since 2004 (a shop's history must outlive
upgrades; DuckDB's storage format changed between releases until 1.0), it takes one
writer at a time with locking (two commands of one shop adding at once wait, they do not
corrupt), and the history is a few rows a recording, far below where a column store pays.
DuckDB still reads it (its `sqlite` extension) for analysis across a fleet.
"""

from __future__ import annotations

import os
from pathlib import Path

from shockdyno.fit.result import FitResult
from shockdyno.history import store
from shockdyno.history.entries import (
    diagnosis_entry,
    diagnosis_options,
    fit_entry,
    fit_options,
    recording_entry,
)
from shockdyno.history.schema import VERSION
from shockdyno.record.types import TestData
from shockdyno.report.documents import DiagnosisDoc, read_diagnosis

ENV = "SHOCKDYNO_HISTORY"
DEFAULT = Path("recordings") / "history.sqlite"

__all__ = ["DEFAULT", "ENV", "VERSION", "default_path", "record_diagnosis", "record_fit"]


def default_path() -> Path:
    """`$SHOCKDYNO_HISTORY`, else recordings/history.sqlite under the working directory."""
    named = os.environ.get(ENV, "").strip()
    return Path(named) if named else DEFAULT


def record_fit(
    db: Path,
    recording: Path,
    result: FitResult,
    result_file: str,
    tests: list[TestData] | None = None,
) -> store.RecordingEntry:
    """Add a fit of `recording` (a FitResult) to the history at `db`."""
    rec = recording_entry(recording, tests)
    store.add(db, rec, fit_entry(result, fit_options(result), result_file))
    return rec


def record_diagnosis(
    db: Path,
    recording: Path,
    doc: DiagnosisDoc,
    result_file: str,
    alpha: float,
    seed: int,
    terms: str,
) -> store.RecordingEntry:
    """Add a diagnosis of `recording` (DIAG.json's document) to the history."""
    rec = recording_entry(recording)
    options = diagnosis_options(doc, alpha, seed, terms)
    store.add(db, rec, diagnosis_entry(doc, options, result_file))
    return rec


def record_result_file(
    db: Path,
    recording: Path,
    kind: str,
    result: Path,
    *,
    alpha: float = 0.01,
    seed: int = 0,
    terms: str = "all",
) -> store.RecordingEntry | None:
    """Add the result a batch task wrote (NAME.fit.json, NAME.diag.json; a diagnosis's
    alpha, seed and terms the batch's); None for a kind the history does not keep (report)."""
    if kind == "fit":
        return record_fit(db, recording, FitResult.load(result), str(result))
    if kind == "diagnose":
        doc = read_diagnosis(result, "diagnose result")
        return record_diagnosis(db, recording, doc, str(result), alpha, seed, terms)
    return None
