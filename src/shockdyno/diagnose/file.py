"""`shockdyno diagnose` on one recording file, as the command and `batch diagnose` both
run it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from shockdyno.errors import ConfigError
from shockdyno.fit.result import FitResult
from shockdyno.fit.terms import split_terms
from shockdyno.model import load_spec
from shockdyno.model.spec import spec_used
from shockdyno.model.terms import LIBRARY
from shockdyno.record import open_recording
from shockdyno.record.identity import provenance, recording_info
from shockdyno.report.documents import DiagnosisDoc, SpecUsed
from shockdyno.result_files import RecordingRef

if TYPE_CHECKING:
    from shockdyno.diagnose.diagnosis import Diagnosis
    from shockdyno.diagnose.engine import Progress


def parse_candidates(text: str) -> tuple[str, ...]:
    """--terms of `diagnose`: `all` or a list of library terms."""
    items = split_terms(text)
    if items == ["all"]:
        return tuple(LIBRARY)
    if "none" in items:
        raise ConfigError("--terms none: diagnose needs at least one candidate term (or all)")
    names = tuple(dict.fromkeys(items))
    for n in names:
        if n not in LIBRARY:
            raise ConfigError(f"--terms: unknown term {n!r} (one of {', '.join(LIBRARY)})")
    return names


def diagnose_file(
    recording: Path,
    *,
    fit_path: str | None = None,
    spec: str | None = None,
    alpha: float = 0.01,
    seed: int = 0,
    terms: str = "all",
    allow_other_recording: bool = False,
    progress: Progress | None = None,
    warn: Callable[[str], None] | None = None,
    workers: int = 1,
) -> tuple[Diagnosis, DiagnosisDoc]:
    """`shockdyno diagnose` on one recording, as `batch diagnose` runs it too: the
    Diagnosis and its DIAG.json document (a DiagnosisDoc, with `info.recording`, the
    spec and the fit's provenance)."""
    # Here, not at the top: the engine and the verdict load about 140 modules (scipy's
    # optimisers, the model's kernels) that `diagnose --help` and a bad argument need not.
    from shockdyno.diagnose.engine import Settings, diagnose
    from shockdyno.diagnose.verdict import document

    if not 0 < alpha < 1:
        raise ConfigError(f"--alpha must be between 0 and 1, got {alpha}")
    settings = Settings(alpha=alpha, seed=seed, candidates=parse_candidates(terms))
    fit = FitResult.load(fit_path).require_usable(f"--fit {fit_path}") if fit_path else None
    if fit is None:
        load_spec(spec)  # a bad spec fails before reading the recording
    info = recording_info(recording)
    fit_from = None
    if fit is not None:
        stored = fit.info.recording_sha256
        fit_from = provenance(stored, info["sha256"], "the fit", "--fit", allow_other_recording)
        if warn is not None and not fit_from.startswith("made from this recording"):
            warn(f"warning: {fit_from}")
    rec = open_recording(recording).require_recording()
    loss = rec.loss_note()
    if loss and warn is not None:
        warn(f"warning: {recording}: {loss}")
    tests = rec.load_all()
    if not tests:
        raise ConfigError(f"{recording}: no tests to diagnose")
    d = diagnose(tests, fit, settings, progress, spec_path=spec, workers=workers)
    doc = document(d)
    # Which damper spec the model started from: --spec, the fit's base spec, or the default.
    used = spec_used(fit.spec_file() if fit is not None else spec)
    made = replace(
        doc.info,
        recording=RecordingRef(**info),
        spec=SpecUsed(**used, from_fit=str(fit_path) if fit is not None else None),
        recording_loss=loss or None,
        fit_provenance=fit_from,
    )
    return d, replace(doc, info=made)
