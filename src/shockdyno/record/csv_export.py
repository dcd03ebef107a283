"""Export a recording to the CSV exchange format (docs/csv.md).

An imported test is written as it came in: the decimal places of a column that had fixed
ones, else the shortest decimal that reads back to the same float64 (Python's repr), so
import then export gives back the same text. A recording from a rig is written at each
channel's own resolution: counts times a calibration (0.05 N a count) land on a decimal grid
up to float64 rounding (229.10000000000002), so a column is written with the fewest decimal
places that read back to within a few float64 steps of every value; a column on no such
grid (a model's force) is written by repr. Either way export, import and export again give
the same text: the second export reads the fixed places the first one wrote.

The velocity column (m/s) is the derivative the analysis takes (a callable from the
caller: record/ does no kinematics), computed from the values as written, so it is the
same after a round trip; import ignores it and the analysis recomputes its own.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shockdyno.atomic import atomic_dir
from shockdyno.errors import RecordingError
from shockdyno.record import adjusters
from shockdyno.record.csv_table import DECIMALS_KEY, VELOCITY_COLUMN
from shockdyno.record.manifest import ADJUSTER_PREFIX, SOURCE_KEY
from shockdyno.record.reader import Recording, open_recording
from shockdyno.record.types import TestData, TestMeta

MANIFEST_NAME = "manifest.csv"
_SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*\.csv")


def _num(v: float | None) -> str:
    return "" if v is None or math.isnan(v) else repr(float(v))


def _file_names(tests: list[TestMeta]) -> list[str]:
    names: list[str] = []
    for k, m in enumerate(tests):
        source = Path(m.extra.get(SOURCE_KEY, "")).name
        name = source if _SAFE_NAME.fullmatch(source) else ""
        if not name or name in names or name == MANIFEST_NAME:
            name = f"test{k:03d}_c{m.clicks:02d}_g{m.gas_clicks:02d}_{m.frequency_hz:g}hz.csv"
        names.append(name)
    return names


MAX_PLACES = 9  # below a nanometre, a nanonewton: no channel of a dyno resolves finer
ROUNDING_STEPS = 8  # float64 steps of the column's magnitude a written value may be off
VELOCITY_PLACES = 6  # µm/s: far below a click chart's 25 mm/s, above any derivative's noise
Differentiate = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


def resolution_places(values: NDArray[np.float64]) -> int | None:
    """The fewest decimal places that write every finite value to within a few float64
    steps of itself (the channel's resolution), or None if none up to MAX_PLACES does."""
    v = values[np.isfinite(values)]
    if v.size == 0:
        return 0
    tol = ROUNDING_STEPS * np.finfo(float).eps * max(float(np.max(np.abs(v))), 1e-300)
    for places in range(MAX_PLACES + 1):
        if float(np.max(np.abs(np.round(v, places) - v))) <= tol:
            return places
    return None


def _formatter(places: int | None) -> Callable[[float], str]:
    if places is None:
        return lambda v: "" if math.isnan(v) else repr(v)
    return lambda v: "" if math.isnan(v) else f"{v:.{places}f}"


def _write_data(path: Path, data: TestData, velocity: Differentiate | None) -> None:
    imported = SOURCE_KEY in data.meta.extra
    known: dict[str, int] = {}
    for item in data.meta.extra.get(DECIMALS_KEY, "").split(","):
        name, _, places = item.partition("=")
        if places.isdigit():
            known[name] = int(places)
    names = ["time_s", "displacement_m", "force_N"]
    cols = [data.t, data.x, data.force]
    if data.temperature is not None:
        names.append("temperature_C")
        cols.append(data.temperature)
    decimals = [
        known.get(n) if imported else resolution_places(c) for n, c in zip(names, cols, strict=True)
    ]
    fmts = [_formatter(p) for p in decimals]
    text = [list(map(fmt, c.tolist())) for fmt, c in zip(fmts, cols, strict=True)]
    # An imported file gains no column it did not have: import then export stays the same.
    if velocity is not None and (not imported or VELOCITY_COLUMN in known):
        t, x = (np.array([float(v) if v else np.nan for v in col]) for col in text[:2])
        fmt = _formatter(known.get(VELOCITY_COLUMN, VELOCITY_PLACES))
        names.append(VELOCITY_COLUMN)
        text.append(list(map(fmt, velocity(t, x).tolist())))
    with open(path, "w", encoding="utf-8", newline="") as out:
        out.write(",".join(names) + "\n")
        out.writelines(",".join(row) + "\n" for row in zip(*text, strict=True))


def _abort_reason(m: TestMeta) -> str:
    """Why a test stopped early: only a test that did not complete has one."""
    return (m.abort_reason or "") if m.status != "complete" else ""


def _write_manifest(path: Path, tests: list[TestMeta], names: list[str]) -> None:
    extras = sorted({k for m in tests for k in m.extra if k not in (SOURCE_KEY, DECIMALS_KEY)})
    window = any(m.measured_start_s is not None for m in tests)
    header = ["file", "clicks", "frequency_hz", "amplitude_m", "gas_clicks"]
    header += ["sample_rate_hz", "motion", "status", "warmup_cycles", "measured_cycles"]
    if window:
        header += ["measured_start_s", "measured_end_s"]
    gas = any(m.gas_pressure_pa is not None for m in tests)
    # A sweep stores its motion check's note there on complete tests too: not a reason.
    reasons = any(_abort_reason(m) for m in tests)
    header += ["gas_pressure_pa"] * gas + ["abort_reason"] * reasons
    # only when a test has one, so an imported recording without it exports as it came
    gas_force = any(m.gas_force_n is not None for m in tests)
    header += ["gas_force_n", "gas_force_source"] * gas_force
    # a constant-velocity test's speed and reversal acceleration, only when a test has one
    stroke = any(m.target_velocity_m_s is not None for m in tests)
    header += ["target_velocity_m_s", "reversal_accel_m_s2"] * stroke
    # a damper with several adjusters: a clicks_NAME column each (none for the one rod)
    named = adjusters.names(m.adjusters for m in tests)
    header += [f"{ADJUSTER_PREFIX}{n}" for n in named]
    header += extras
    with open(path, "w", encoding="utf-8", newline="") as out:
        w = csv.writer(out, lineterminator="\n")
        w.writerow(header)
        for m, name in zip(tests, names, strict=True):
            row = [name, str(m.clicks), _num(m.frequency_hz), _num(m.amplitude_m)]
            row += [str(m.gas_clicks), _num(m.sample_rate_hz), m.motion, m.status]
            row += [str(m.warmup_cycles), str(m.measured_cycles)]
            if window:
                row += [_num(m.measured_start_s), _num(m.measured_end_s)]
            if gas:
                row.append(_num(m.gas_pressure_pa))
            if reasons:
                row.append(_abort_reason(m))
            if gas_force:
                known = m.gas_force_n is not None
                row += [_num(m.gas_force_n) if known else "", (m.gas_force_source or "") * known]
            if stroke:
                row += [_num(m.target_velocity_m_s), _num(m.reversal_accel_m_s2)]
            row += [str(m.adjusters.get(n, "")) for n in named]
            row += [m.extra.get(k, "") for k in extras]
            w.writerow(row)


def export_csv(
    recording: Path | Recording,
    out_dir: Path,
    *,
    force: bool = False,
    velocity: Differentiate | None = None,
) -> list[Path]:
    """Write DIR/manifest.csv and one data CSV per test (complete and aborted; a damaged
    one is left out: its samples are a part of the test, `Recording.loss_note` names it);
    with `velocity` (t, x -> dx/dt), a velocity_m_s column as well (see the module's doc)."""
    rec = recording if isinstance(recording, Recording) else open_recording(recording)
    kept = [i for i, m in enumerate(rec.tests) if m.status != "damaged"]
    if not kept:
        damaged = f" ({len(rec.damaged)} damaged)" if rec.damaged else ""
        raise RecordingError(f"{rec.path}: no complete or aborted test to export{damaged}")
    metas = [rec.tests[i] for i in kept]
    names = _file_names(metas)
    with atomic_dir(out_dir, force) as tmp:
        try:
            for i, name in zip(kept, names, strict=True):
                _write_data(tmp / name, rec.load(i), velocity)
            _write_manifest(tmp / MANIFEST_NAME, metas, names)
        except OSError as exc:
            raise RecordingError(f"cannot write {out_dir}: {exc.strerror}") from exc
    return [out_dir / MANIFEST_NAME, *(out_dir / n for n in names)]
