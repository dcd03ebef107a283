"""Export a recording to the CSV exchange format (docs/csv.md).

Numbers are written as the shortest decimal that reads back to the same float64 (Python's
repr), so importing an exchange-format file and exporting it again gives back the same values.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Callable
from pathlib import Path

from shockdyno.errors import RecordingError
from shockdyno.record.atomic import atomic_dir
from shockdyno.record.csv_import import DECIMALS_KEY, SOURCE_KEY
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


def _formatter(places: int | None) -> Callable[[float], str]:
    if places is None:
        return lambda v: "" if math.isnan(v) else repr(v)
    return lambda v: "" if math.isnan(v) else f"{v:.{places}f}"


def _write_data(path: Path, data: TestData) -> None:
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
    fmts = [_formatter(known.get(n)) for n in names]
    text = [list(map(fmt, c.tolist())) for fmt, c in zip(fmts, cols, strict=True)]
    with open(path, "w", encoding="utf-8", newline="") as out:
        out.write(",".join(names) + "\n")
        out.writelines(",".join(row) + "\n" for row in zip(*text, strict=True))


def _write_manifest(path: Path, tests: list[TestMeta], names: list[str]) -> None:
    extras = sorted({k for m in tests for k in m.extra if k not in (SOURCE_KEY, DECIMALS_KEY)})
    window = any(m.measured_start_s is not None for m in tests)
    header = ["file", "clicks", "frequency_hz", "amplitude_m", "gas_clicks"]
    header += ["sample_rate_hz", "motion", "status", "warmup_cycles", "measured_cycles"]
    if window:
        header += ["measured_start_s", "measured_end_s"]
    gas = any(m.gas_pressure_pa is not None for m in tests)
    reasons = any(m.abort_reason for m in tests)
    header += ["gas_pressure_pa"] * gas + ["abort_reason"] * reasons
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
                row.append(m.abort_reason or "")
            row += [m.extra.get(k, "") for k in extras]
            w.writerow(row)


def export_csv(recording: Path | Recording, out_dir: Path, *, force: bool = False) -> list[Path]:
    """Write DIR/manifest.csv and one data CSV per test (complete and aborted)."""
    rec = recording if isinstance(recording, Recording) else open_recording(recording)
    if not rec.tests:
        raise RecordingError(f"{rec.path}: no complete or aborted test to export")
    names = _file_names(rec.tests)
    with atomic_dir(out_dir, force) as tmp:
        try:
            for i, name in enumerate(names):
                _write_data(tmp / name, rec.load(i))
            _write_manifest(tmp / MANIFEST_NAME, rec.tests, names)
        except OSError as exc:
            raise RecordingError(f"cannot write {out_dir}: {exc.strerror}") from exc
    return [out_dir / MANIFEST_NAME, *(out_dir / n for n in names)]
