"""The import manifest: one row per test (its click setting, frequency, amplitude and data
file), checked cell by cell, and where a data file may lie (docs/csv.md)."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from shockdyno.errors import RecordingError
from shockdyno.record.csv_table import (
    DECIMALS_KEY,
    MOTIONS,
    CsvTable,
    ImportOptions,
    read_data_csv,
)
from shockdyno.record.plausible import (
    MAX_AMPLITUDE_M,
    MAX_CLICKS,
    MAX_FREQUENCY_HZ,
    MAX_SAMPLE_RATE_HZ,
    check_setting,
)
from shockdyno.record.types import TestMeta
from shockdyno.samples import SampleBlock

MANIFEST_REQUIRED = ("file", "clicks", "frequency_hz", "amplitude_m")
# Manifest columns that map onto TestMeta fields; any other column is kept in TestMeta.extra.
MANIFEST_KNOWN = (
    *MANIFEST_REQUIRED,
    "gas_clicks",
    "sample_rate_hz",
    "motion",
    "target_velocity_m_s",
    "reversal_accel_m_s2",
    "warmup_cycles",
    "measured_cycles",
    "measured_start_s",
    "measured_end_s",
    "status",
    "gas_pressure_pa",
    "abort_reason",
    "gas_force_n",  # the static gas force at mid-stroke, as the sweep measured it
    "gas_force_source",  # "measured" | "estimated"
)
GAS_FORCE_SOURCES = ("measured", "estimated")
# `clicks_NAME`: that adjuster's clicks, for a damper with several (docs/adjusters.md)
ADJUSTER_PREFIX = "clicks_"
SOURCE_KEY = "csv_file"  # TestMeta.extra key: the data file a test was imported from


@dataclass
class ImportedTest:
    meta: TestMeta
    block: SampleBlock


def _int_cell(table: CsvTable, i: int, col: int) -> int:
    v = table.rows[i][col].strip()
    try:
        return int(v)
    except ValueError:
        raise RecordingError(f"{table.where(i, col)}: {v!r} is not a whole number") from None


def _float_cell(table: CsvTable, i: int, col: int, *, positive: bool = False) -> float:
    v = table.rows[i][col].strip()
    try:
        x = float(v)
    except ValueError:
        raise RecordingError(f"{table.where(i, col)}: {v!r} is not a number") from None
    if not math.isfinite(x) or x < 0 or (positive and x == 0):
        need = "positive" if positive else "zero or positive"
        raise RecordingError(f"{table.where(i, col)}: {v!r} must be {need}")
    return x


def read_manifest(
    manifest: Path,
    opts: ImportOptions,
    progress: Callable[[str, float], None] | None = None,
) -> list[ImportedTest]:
    opts.check()
    table = CsvTable(manifest, opts.delimiter, opts.max_file_bytes)
    cols = {name: table.column(name) for name in MANIFEST_REQUIRED}
    for name in MANIFEST_KNOWN:
        if name in table.header:
            cols[name] = table.header.index(name)
    if not table.rows:
        raise RecordingError(f"{manifest}:2: the manifest lists no tests")
    tests = []
    for i, row in enumerate(table.rows):

        def cell(name: str, row: list[str] = row) -> str:
            return row[cols[name]].strip() if name in cols else ""

        file_name = cell("file")
        if progress is not None:
            progress(f"read {file_name}", 0.5 * i / len(table.rows))
        if not file_name:
            raise RecordingError(f"{table.where(i, cols['file'])}: no file name")
        clicks = _int_cell(table, i, cols["clicks"])
        gas = _int_cell(table, i, cols["gas_clicks"]) if cell("gas_clicks") else opts.gas_clicks
        for name, value in (("clicks", clicks), ("gas_clicks", gas)):
            if value < 0:
                raise RecordingError(f"{table.where(i, cols[name])}: {value} must not be negative")
        freq = _float_cell(table, i, cols["frequency_hz"], positive=True)
        amp = _float_cell(table, i, cols["amplitude_m"])
        settings: tuple[tuple[str, float, float], ...] = (
            ("clicks", clicks, MAX_CLICKS),
            ("gas_clicks", gas, MAX_CLICKS),
            ("frequency_hz", freq, MAX_FREQUENCY_HZ),
            ("amplitude_m", amp, MAX_AMPLITUDE_M),
        )
        for name, setting, limit in settings:
            where = table.where(i, cols[name]) if name in cols else f"{manifest} (--gas-clicks)"
            check_setting(where, name, setting, limit)
        motion = cell("motion") or opts.motion or "sine"
        if motion not in MOTIONS:
            raise RecordingError(
                f"{table.where(i, cols['motion'])}: {motion!r} is not one of {', '.join(MOTIONS)}"
            )
        status = cell("status") or "complete"
        if status not in ("complete", "aborted", "degraded"):  # export writes all three
            raise RecordingError(
                f"{table.where(i, cols['status'])}: {status!r} is not complete, aborted or degraded"
            )
        path = _data_path(manifest, file_name, opts.allow_outside, table.where(i, cols["file"]))
        block, places = read_data_csv(path, opts)
        if cell("sample_rate_hz"):
            rate = _float_cell(table, i, cols["sample_rate_hz"], positive=True)
        elif opts.sample_rate_hz is not None:
            rate = opts.sample_rate_hz
        elif len(block) >= 2:
            rate = float(f"{1.0 / float(np.median(np.diff(block.t_s))):.6g}")
        else:
            raise RecordingError(f"{path}: one sample; give the sample rate (--sample-rate-hz)")
        check_setting(str(path), "sample rate (Hz)", rate, MAX_SAMPLE_RATE_HZ)
        if motion == "sine" and amp > 0 and len(block):
            top, bottom = float(block.displacement_m.max()), float(block.displacement_m.min())
            peak = (top - bottom) / 2
            if peak > 100 * amp or peak < amp / 100:
                print(
                    f"warning: {path}: data swings ±{peak:.3g} m, the manifest says "
                    f"amplitude_m {amp:g} (a unit mix-up?)",
                    file=sys.stderr,
                )
        window = [
            _float_cell(table, i, cols[name]) if cell(name) else None
            for name in ("measured_start_s", "measured_end_s")
        ]
        named: dict[str, int] = {}  # a damper with several adjusters: clicks_NAME each
        for j, h in enumerate(table.header):
            if h.startswith(ADJUSTER_PREFIX) and len(h) > len(ADJUSTER_PREFIX):
                value = _int_cell(table, i, j)
                if value < 0:
                    raise RecordingError(f"{table.where(i, j)}: {value} must not be negative")
                check_setting(table.where(i, j), h, value, MAX_CLICKS)
                named[h[len(ADJUSTER_PREFIX) :]] = value
        extra = {
            h: row[j].strip()
            for j, h in enumerate(table.header)
            if h not in MANIFEST_KNOWN
            and h not in (SOURCE_KEY, DECIMALS_KEY)
            and not h.startswith(ADJUSTER_PREFIX)
        }
        extra[SOURCE_KEY] = file_name
        if places:
            extra[DECIMALS_KEY] = places
        meta = TestMeta(
            index=i,
            clicks=clicks,
            gas_clicks=gas,
            frequency_hz=freq,
            amplitude_m=amp,
            sample_rate_hz=rate,
            warmup_cycles=_int_cell(table, i, cols["warmup_cycles"])
            if cell("warmup_cycles")
            else 0,
            measured_cycles=(
                _int_cell(table, i, cols["measured_cycles"]) if cell("measured_cycles") else 0
            ),
            motion=motion,
            measured_start_s=window[0],
            measured_end_s=window[1],
            status=status,
            extra=extra,
            adjusters=named,
            dropped_frames=0,
            gas_pressure_pa=(
                _float_cell(table, i, cols["gas_pressure_pa"], positive=True)
                if cell("gas_pressure_pa")
                else None
            ),
            abort_reason=cell("abort_reason") or None,
            **_gas_force(table, i, cols, cell),
            **_stroke(table, i, cols, cell, motion),
        )
        tests.append(ImportedTest(meta, block))
    return tests


def _stroke(
    table: CsvTable, i: int, cols: dict[str, int], cell: Callable[[str], str], motion: str
) -> dict[str, Any]:
    """A constant-velocity test's speed and reversal acceleration (export writes them)."""
    out: dict[str, Any] = {}
    for name in ("target_velocity_m_s", "reversal_accel_m_s2"):
        if cell(name):
            out[name] = _float_cell(table, i, cols[name], positive=True)
    if motion in ("triangle", "trapezoid") and "target_velocity_m_s" not in out:
        where = table.where(i, cols["motion"] if "motion" in cols else cols["file"])
        raise RecordingError(f"{where}: a {motion} test needs its target_velocity_m_s column")
    return out


def _gas_force(
    table: CsvTable, i: int, cols: dict[str, int], cell: Callable[[str], str]
) -> dict[str, Any]:
    """The manifest's gas force of a test (export writes the recording's), with its source:
    a number alone is taken as measured."""
    if not cell("gas_force_n"):
        return {}
    value = _float_cell(table, i, cols["gas_force_n"])
    source = cell("gas_force_source") or "measured"
    if source not in GAS_FORCE_SOURCES:
        where = table.where(i, cols["gas_force_source"])
        raise RecordingError(f"{where}: {source!r} is not one of {', '.join(GAS_FORCE_SOURCES)}")
    return {"gas_force_n": value, "gas_force_source": source}


def _data_path(manifest: Path, name: str, allow_outside: bool, where: str) -> Path:
    """A manifest's data file; it must lie under the manifest's folder unless allowed."""
    if "\x00" in name:  # no file system takes it; os.path raised ValueError on it
        raise RecordingError(f"{where}: {name!r} holds a NUL character: not a file name")
    path = manifest.parent / name
    if allow_outside:
        return path
    folder = manifest.parent.resolve()
    resolved = path.resolve()
    if Path(name).is_absolute() or not resolved.is_relative_to(folder):
        raise RecordingError(
            f"{where}: {name!r} lies outside the manifest's folder {folder} "
            "(--allow-outside-files to read it)"
        )
    return path
