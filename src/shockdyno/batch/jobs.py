"""One recording, one task: what a Dask worker runs for `batch fit|diagnose|report`.

A task writes the same file the single command writes (`NAME.fit.json`,
`NAME.diag.json`, `NAME/index.html`), atomically, then a key file
(`.batch/NAME.KIND.json`: the recording's hash, the options and the version) that lets a
re-run skip it. A task that dies between the two leaves a complete result and no key:
the re-run writes the same result again, atomically, and nothing is written twice into
one file. Every error becomes the row's one-line `error`, never the batch's end.
"""

from __future__ import annotations

import contextlib
import importlib
import json
import os
import time
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TypedDict

from shockdyno import __version__
from shockdyno.atomic import staged_dir, write_text_atomic
from shockdyno.batch.table import Row
from shockdyno.diagnose.file import diagnose_file
from shockdyno.errors import ConfigError, ShockdynoError
from shockdyno.fit import forces
from shockdyno.fit.file import fit_file, result_json
from shockdyno.fit.result import FitResult
from shockdyno.record import open_recording
from shockdyno.record.identity import provenance
from shockdyno.record.types import TestData
from shockdyno.report.documents import DiagnosisDoc, diagnosis_text, read_diagnosis
from shockdyno.report.gas import limit_for

SUFFIX = {"fit": ".fit.json", "diagnose": ".diag.json", "report": "/index.html"}
# Test-only: seconds the first task of each worker process waits before its work, so a
# test can kill a worker while it holds one (the later tasks need not wait: each waited
# 5 s, 15 s of the killed-worker test's sleep). Unset in normal use.
DELAY_ENV = "SHOCKDYNO_BATCH_TEST_DELAY_S"
_waited: list[bool] = []  # this process's first task has waited


class Options(TypedDict, total=False):
    """A batch's options, as the command gives them (commands/batch.py) and a task's key
    stores them: only those given are present."""

    seed: int
    spec: str
    fit: str
    allow_other_recording: bool
    optimizer: str
    terms: str
    alpha: float


class Key(TypedDict):
    """`.batch/NAME.KIND.json`: what the result was made from."""

    sha256: str
    options: Options
    version: str


@dataclass(frozen=True)
class Job:
    kind: str
    recording: str
    name: str  # the result's file name stem in the output folder
    sha256: str
    out_dir: str
    options: Options = field(default_factory=Options)

    @property
    def result_path(self) -> Path:
        return Path(self.out_dir) / f"{self.name}{SUFFIX[self.kind]}"

    @property
    def key_path(self) -> Path:
        return Path(self.out_dir) / ".batch" / f"{self.name}.{self.kind}.json"

    def key(self) -> Key:
        return {"sha256": self.sha256, "options": self.options, "version": __version__}


# What a task of each kind imports and loads on its first use. The batch's process does it
# once before its local workers are forked from it (batch/local.py); each worker did it in
# its first fit otherwise: 0.55 s of CPU a worker, scipy.optimize 0.30 s and numba's CPU
# target 0.23 s (measured). Only speed: a name missing here is imported by the task.
WARM = {
    "fit": ["scipy.optimize"],
    "diagnose": [
        "scipy.optimize",
        "shockdyno.diagnose.engine",
        "shockdyno.diagnose.verdict",
        "shockdyno.diagnose.plots",
        "shockdyno.diagnose.report",
    ],
    "report": ["shockdyno.report.build", "shockdyno.fit.plots"],
}


def warm_up(kinds: Iterable[str]) -> None:
    """Import and load here what tasks of these kinds would on their first use (WARM)."""
    from numba.core.registry import cpu_target

    for name in dict.fromkeys(n for kind in kinds for n in WARM[kind]):
        importlib.import_module(name)
    cpu_target.target_context.refresh()  # the registries each compiled kernel's load needs


def done_already(job: Job) -> bool:
    """The result exists and was made from the same bytes, options and version."""
    try:
        stored = json.loads(job.key_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return bool(stored == job.key() and job.result_path.exists())


def run_job(job: Job) -> Row:
    """The worker's task: the row of one recording (never raises for a bad recording)."""
    t0 = time.perf_counter()
    row = Row(job.recording, job.name, job.sha256, job.kind, "done")
    try:
        if done_already(job):
            row.status = "skipped"
            _describe(row, job)
            return row
        delay = float(os.environ.get(DELAY_ENV, "0") or 0)
        if delay > 0 and not _waited:
            _waited.append(True)
            time.sleep(delay)
        _RUN[job.kind](job, row)
        job.key_path.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(job.key_path, json.dumps(job.key(), sort_keys=True) + "\n")
        row.result = str(job.result_path)
    except Exception as exc:  # one bad recording is a row, never the batch's end
        row.status = "failed"
        text = " ".join(str(exc).split())[:500]
        row.error = text if isinstance(exc, ShockdynoError) else f"{type(exc).__name__}: {text}"
    row.wall_s = time.perf_counter() - t0
    return row


def _fit(job: Job, row: Row) -> None:
    o = job.options
    result, tests = fit_file(
        Path(job.recording),
        spec=o.get("spec"),
        optimizer=o.get("optimizer", "fast"),
        seed=int(o.get("seed", 0)),
        terms=o.get("terms"),
    )
    text = result_json(result)
    write_text_atomic(job.result_path, text)
    if result.saved is not None:  # what `batch report` draws of the model, beside it
        forces.write(forces.sidecar_path(job.result_path), result.saved, text)
    _from_tests(row, tests)
    row.damper_id = _damper_id(job.recording)
    e_t = [t.proposed.get("E_t") for t in result.tests]
    row.e_t_after = _mean(e_t)
    row.physics = ";".join(sorted(result.terms))
    moved = {k: v for k, v in result.globals.items()}
    row.calibration = ";".join(f"{k}={v:.6g}" for k, v in sorted(moved.items()))


def _diagnose(job: Job, row: Row) -> None:
    # The figures' modules are imported when drawn: matplotlib would add 620 ms CPU to
    # every command's start-up (commands/batch.py imports this module; measured).
    from shockdyno.diagnose.plots import loops, residual_maps
    from shockdyno.diagnose.report import FIGURES, figure_paths

    o = job.options
    d, doc = diagnose_file(
        Path(job.recording),
        fit_path=fit_for(job),
        spec=o.get("spec"),
        alpha=float(o.get("alpha", 0.01)),
        seed=int(o.get("seed", 0)),
        terms=o.get("terms", "all"),
        allow_other_recording=bool(o.get("allow_other_recording", False)),
    )
    # Its residual maps and loops beside it, named in it: `batch report` shows them. The
    # JSON first: a plotting failure must not lose the diagnosis.
    figures = Path(job.out_dir) / f"{job.name}.diagnose"
    doc = replace(doc, info=replace(doc.info, figures=figure_paths(figures, str(job.result_path))))
    write_text_atomic(job.result_path, diagnosis_text(doc))
    figures.mkdir(exist_ok=True)
    residual_maps(d, figures / FIGURES["residual_maps"])
    loops(d, figures / FIGURES["loops"])
    _from_tests(row, [p.data for p in d.data.prepared])
    row.damper_id = _damper_id(job.recording)
    _from_diag(row, doc)


def _report(job: Job, row: Row) -> None:
    from shockdyno.report.build import build_report  # matplotlib: +460 ms, as above

    rec = open_recording(job.recording).require_recording()
    tests = rec.load_all()
    fit_path = fit_for(job)
    fit = FitResult.load(fit_path).require_usable(f"--fit {fit_path}") if fit_path else None
    if fit is not None and fit_path is not None:  # the page reads the forces the fit saved
        forces.attach(fit, fit_path, job.sha256)  # none: computed from the fit, as before
    diag_path = Path(job.out_dir) / f"{job.name}.diag.json"
    diag = read_diagnosis(diag_path, "diagnose result") if diag_path.exists() else None
    out = Path(job.out_dir) / job.name
    title = f"{rec.metadata.get('damper_id') or job.name}: dyno report"
    metadata = {"recording": Path(job.recording).name, **rec.metadata}
    limit = limit_for(tests, job.options.get("spec"), rec.metadata, fit.spec() if fit else None)
    if fit is not None:  # a fit of another recording is refused, as by `report` (issue 46.7)
        stored = fit.info.recording_sha256
        allow = bool(job.options.get("allow_other_recording", False))
        metadata["fit"] = provenance(stored, job.sha256, "the fit", "--fit", allow)
    with staged_dir(out) as folder:  # whole, or not at all: a killed worker leaves none
        build_report(tests, folder, title=title, metadata=metadata, fit=fit, diagnose=diag,
                     diagnose_dir=diag_path.parent, gas_limit=limit)  # fmt: skip
    if fit is not None and fit_path is not None:
        row.note = forces.computed_note(fit, fit_path)
    _from_tests(row, tests)
    row.damper_id = rec.metadata.get("damper_id", "")
    if diag is not None:
        _from_diag(row, diag)


_RUN = {"fit": _fit, "diagnose": _diagnose, "report": _report}


def fit_for(job: Job) -> str | None:
    """--fit: a file for every recording, or a folder of NAME.fit.json (a batch fit's);
    None for a recording the folder has no fit of (it runs without one: `missing_fits`)."""
    given = job.options.get("fit")
    if not given:
        return None
    p = Path(given)
    if p.is_dir():
        candidate = p / f"{job.name}.fit.json"
        return str(candidate) if candidate.exists() else None
    return str(p)


def missing_fits(jobs: list[Job]) -> list[str]:
    """The recordings a --fit folder has no NAME.fit.json of, by name."""
    return [j.name for j in jobs if j.options.get("fit") and fit_for(j) is None]


def sidecar_notes(jobs: list[Job]) -> list[str]:
    """`batch report`: one line for each fit whose saved model forces (fit/forces.py) the
    pages will not read (missing, stale, unreadable) and compute instead, as `report` says."""
    notes: dict[str, str] = {}
    for job in jobs:
        path = fit_for(job) if job.kind == "report" else None
        if path is not None and path not in notes:
            notes[path] = forces.read(path)[1]
    return [note for note in notes.values() if note]


def computed_notes(jobs: list[Job], rows: list[Row]) -> list[str]:
    """`batch report`, after the work: one line for each fit whose saved model forces did
    not hold what its pages drew (`report`'s note), naming the pages that computed it."""
    fit_of = {(j.name, j.kind): fit_for(j) for j in jobs}
    by_fit: dict[str, list[Row]] = {}
    for row in rows:
        path = fit_of.get((row.name, row.kind))
        if row.note and path is not None:
            by_fit.setdefault(path, []).append(row)
    lines = []
    for noted in by_fit.values():
        names = ", ".join(r.name for r in noted[:5]) + (
            f" and {len(noted) - 5} more" if len(noted) > 5 else ""
        )
        page = "page" if len(noted) == 1 else "pages"
        lines.append(f"{noted[0].note}, for {len(noted)} {page} ({names})")
    return lines


def _damper_id(recording: str) -> str:
    """The damper id the recording's metadata holds (`sweep --damper-id`, `import --meta`)."""
    return open_recording(recording).metadata.get("damper_id", "")


def _describe(row: Row, job: Job) -> None:
    """A skipped row still says what the result holds."""
    if not job.result_path.exists():
        return
    with contextlib.suppress(ShockdynoError):  # the row is still a skip without it
        row.damper_id = _damper_id(job.recording)
    row.result = str(job.result_path)
    if job.kind == "diagnose":
        with contextlib.suppress(ConfigError):  # an unreadable result describes nothing
            _from_diag(row, read_diagnosis(job.result_path, "diagnose result"))


def _from_tests(row: Row, tests: list[TestData]) -> None:
    metas = [t.meta for t in tests]
    row.clicks = ",".join(str(c) for c in sorted({m.clicks for m in metas}))
    row.frequencies_hz = ",".join(f"{f:g}" for f in sorted({m.frequency_hz for m in metas}))


def _from_diag(row: Row, doc: DiagnosisDoc) -> None:
    row.physics = ";".join(doc.verdict.physics)
    # A finding (beyond a damper's tolerance, or at an end of the calibration's range) is
    # not a spec's error, and the table says which is which, as the verdict does.
    row.calibration = ";".join(
        f"{r.parameter}={r.fitted / (r.written or r.spec_value):.3g}x"
        + (" the recording's" if r.written else "")
        + (" (finding)" if r.beyond_tolerance or r.at_range_end else "")
        for r in doc.verdict.calibration
        if r.moved and r.spec_value
    )
    row.e_t_before = _mean([t.E_t_before for t in doc.tests])
    row.e_t_after = _mean([t.E_t_after for t in doc.tests])


def _mean(values: list[float | None]) -> float | None:
    ok = [v for v in values if v is not None]
    return sum(ok) / len(ok) if ok else None
