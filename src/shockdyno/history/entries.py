"""A history entry from what `fit`, `diagnose` and `batch` already have: the recording's
file (identity, metadata, gas force) and the result they wrote (FIT.json, DIAG.json)."""

from __future__ import annotations

import math
import os
import statistics
import time
from datetime import UTC, datetime
from pathlib import Path

from shockdyno import __version__
from shockdyno.fit.result import FitResult
from shockdyno.history.store import (
    AreaEntry,
    GasEntry,
    ParameterEntry,
    RecordingEntry,
    ResultEntry,
)
from shockdyno.record import open_recording
from shockdyno.record.identity import recording_sha256
from shockdyno.record.types import TestData
from shockdyno.report.documents import DiagnosisDoc
from shockdyno.report.gas import gas_forces, limit_for
from shockdyno.schema import finite_or_none

# A spec global's unit by its name's ending (the fit JSON's globals are SI by name).
UNITS = (("_pa", "Pa"), ("_n", "N"), ("_m2", "m²"), ("_m", "m"), ("_kg", "kg"),
         ("_m_s", "m/s"), ("_s", "s"), ("_cst", "cSt"), ("_kg_m3", "kg/m³"))  # fmt: skip


def now_utc() -> str:
    """The time now in UTC as ISO 8601 to the second (YYYY-MM-DDTHH:MM:SSZ), as the history
    stores times."""
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


def _unit(name: str) -> str:
    matches = [u for end, u in UNITS if name.endswith(end)]
    return matches[-1] if matches else ""


def recording_entry(path: Path, tests: list[TestData] | None = None) -> RecordingEntry:
    """The recording at `path`: its SHA-256, metadata, click settings and gas force (the
    report's: measured, else estimated within the charge of the spec it names)."""
    rec = open_recording(path)
    if tests is None:
        tests = rec.load_all()
    meta = rec.metadata
    when = meta.get("created_utc") or datetime.fromtimestamp(os.stat(path).st_mtime, UTC).strftime(
        "%Y-%m-%dT%H:%M:%SZ"
    )
    forces = gas_forces(tests, limit=limit_for(tests, metadata=meta))
    gas = tuple(
        GasEntry(g, f.value_n if f.value_n is not None else None, finite_or_none(f.sd_n), f.source)
        for g, f in sorted(forces.items())
    )
    return RecordingEntry(
        sha256=recording_sha256(path),
        file=str(path),
        damper_id=meta.get("damper_id", ""),
        operator=meta.get("operator", ""),
        recorded_utc=when,
        rig=meta.get("rig", ""),
        notes=meta.get("notes", ""),
        clicks=",".join(str(c) for c in sorted({t.meta.clicks for t in tests})),
        gas_clicks=",".join(str(c) for c in sorted({t.meta.gas_clicks for t in tests})),
        n_tests=len(tests),
        gas=gas,
    )


def _mean(values: list[float | None]) -> float | None:
    ok = [float(v) for v in values if v is not None and math.isfinite(v)]
    return statistics.fmean(ok) if ok else None


def fit_entry(result: FitResult, options: dict[str, object], result_file: str) -> ResultEntry:
    """A FitResult: its areas per click, globals and term parameters with their σ, E_t."""
    cal = result.info.calibration
    sd = cal.globals_sd if cal is not None else {}
    params = [
        ParameterEntry(k, float(v), finite_or_none(sd.get(k)), _unit(k))
        for k, v in sorted(result.globals.items())
    ]
    params += [
        ParameterEntry(f"{term}.{k}", finite_or_none(est.value), finite_or_none(est.sd), est.unit)
        for term, values in sorted(result.terms.items())
        for k, est in sorted(values.items())
    ]
    # A damper with several adjusters: the first adjuster's line (the others at the base),
    # its clicks as the history's clicks; the rest of its areas are in FIT.json.
    names = result.adjuster_names()
    clicks = result.for_adjuster(names[0]).clicks if names else result.clicks
    areas = [
        AreaEntry(c.clicks, c.gas_clicks, finite_or_none(c.a_bc_m2), finite_or_none(c.a_bt_m2),
                  finite_or_none(c.a_bc_sd_m2), finite_or_none(c.a_bt_sd_m2))
        for c in clicks
    ]  # fmt: skip
    return ResultEntry(  # made now, by this version
        "fit",
        options,
        now_utc(),
        result_file,
        __version__,
        e_t=_mean([t.proposed.get("E_t") for t in result.tests]),
        physics=",".join(sorted(result.terms)),
        areas=tuple(areas),
        parameters=tuple(params),
    )


def diagnosis_entry(doc: DiagnosisDoc, options: dict[str, object], result_file: str) -> ResultEntry:
    """A DiagnosisDoc: the physics claimed, the verdict, E_t before and after, and the spec
    values it calibrated."""
    params = [
        ParameterEntry(c.parameter, finite_or_none(c.fitted), finite_or_none(c.sd), c.unit)
        for c in doc.verdict.calibration
    ]
    return ResultEntry(  # made now, by this version
        "diagnose",
        options,
        now_utc(),
        result_file,
        __version__,
        e_t=_mean([t.E_t_after for t in doc.tests]),
        e_t_before=_mean([t.E_t_before for t in doc.tests]),
        physics=",".join(doc.verdict.physics),
        verdict=doc.verdict.text,
        parameters=tuple(params),
    )


def fit_options(result: FitResult) -> dict[str, object]:
    """What shapes a fit, as its result records it (so `fit` and `batch fit` of the same
    recording with the same settings are one result, however the options were spelt)."""
    info = result.info
    return {
        "optimizer": info.optimizer,
        "seed": info.seed,
        "terms": list(info.terms) if info.terms is not None else None,
        "spec": Path(result.spec_path).name,
    }


def diagnosis_options(doc: DiagnosisDoc, alpha: float, seed: int, terms: str) -> dict[str, object]:
    """What shapes a diagnosis: its significance, seed, candidate terms and spec."""
    spec = doc.info.spec.path if doc.info.spec is not None else ""
    named = sorted({t.strip() for t in terms.split(",") if t.strip()})
    return {"alpha": alpha, "seed": seed, "terms": named, "spec": Path(spec).name}
