"""The import manifest: one row per test (its click setting, frequency, amplitude and data
file), checked cell by cell, and where a data file may lie (docs/csv.md)."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

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
    """One test read from a manifest row: its metadata and its samples in SI."""

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


@dataclass(frozen=True)
class _Row:
    """One manifest row's cells by column name, and where each stands for an error."""

    manifest: Path
    table: CsvTable
    cols: dict[str, int]  # the known columns the manifest has: their index
    i: int

    def cell(self, name: str) -> str:
        """The cell, stripped; empty when the manifest has no such column."""
        return self.table.rows[self.i][self.cols[name]].strip() if name in self.cols else ""

    def where(self, name: str) -> str:
        """`FILE:LINE: column 'NAME'` of this row's cell, for an error message."""
        return self.table.where(self.i, self.cols[name])

    def whole(self, name: str) -> int:
        """The cell as a whole number; RecordingError naming the cell otherwise."""
        return _int_cell(self.table, self.i, self.cols[name])

    def number(self, name: str, *, positive: bool = False) -> float:
        """The cell as a finite number ≥ 0 (> 0 with `positive`); RecordingError naming the cell
        otherwise."""
        return _float_cell(self.table, self.i, self.cols[name], positive=positive)


def read_manifest(
    manifest: Path,
    opts: ImportOptions,
    progress: Callable[[str, float], None] | None = None,
) -> list[ImportedTest]:
    """Every test a manifest CSV lists (`file,clicks,frequency_hz,amplitude_m`, more columns
    allowed), each data file read and converted to SI; RecordingError naming the file, line and
    column of the first problem. `progress` gets (what, share done)."""
    opts.check()
    table = CsvTable(manifest, opts.delimiter, opts.max_file_bytes)
    cols = {name: table.column(name) for name in MANIFEST_REQUIRED}
    for name in MANIFEST_KNOWN:
        if name in table.header:
            cols[name] = table.header.index(name)
    if not table.rows:
        raise RecordingError(f"{manifest}:2: the manifest lists no tests")
    tests = []
    for i in range(len(table.rows)):
        row = _Row(manifest, table, cols, i)
        if progress is not None:
            progress(f"read {row.cell('file')}", 0.5 * i / len(table.rows))
        tests.append(_read_test(row, opts))
    return tests


def _read_test(row: _Row, opts: ImportOptions) -> ImportedTest:
    """One manifest row and its data file, checked in the order the cells stand."""
    file_name = row.cell("file")
    if not file_name:
        raise RecordingError(f"{row.where('file')}: no file name")
    clicks, gas, freq, amp = _setting(row, opts)
    motion = row.cell("motion") or opts.motion or "sine"
    if motion not in MOTIONS:
        raise RecordingError(
            f"{row.where('motion')}: {motion!r} is not one of {', '.join(MOTIONS)}"
        )
    status = row.cell("status") or "complete"
    if status not in ("complete", "aborted", "degraded"):  # export writes all three
        raise RecordingError(
            f"{row.where('status')}: {status!r} is not complete, aborted or degraded"
        )
    path = _data_path(row.manifest, file_name, opts.allow_outside, row.where("file"))
    block, places = read_data_csv(path, opts)
    rate = _sample_rate(row, opts, path, block)
    if motion == "sine":
        _warn_amplitude(path, block, amp)
    start_s, end_s = (
        row.number(name) if row.cell(name) else None
        for name in ("measured_start_s", "measured_end_s")
    )
    adjusters = _adjusters(row)
    extra = _extra(row, file_name, places)
    warmup = row.whole("warmup_cycles") if row.cell("warmup_cycles") else 0
    measured = row.whole("measured_cycles") if row.cell("measured_cycles") else 0
    gas_pa = row.number("gas_pressure_pa", positive=True) if row.cell("gas_pressure_pa") else None
    gas_force_n, gas_force_source = _gas_force(row)
    target_velocity_m_s, reversal_accel_m_s2 = _stroke(row, motion)
    meta = TestMeta(
        index=row.i,
        clicks=clicks,
        gas_clicks=gas,
        frequency_hz=freq,
        amplitude_m=amp,
        sample_rate_hz=rate,
        warmup_cycles=warmup,
        measured_cycles=measured,
        motion=motion,
        measured_start_s=start_s,
        measured_end_s=end_s,
        status=status,
        extra=extra,
        adjusters=adjusters,
        dropped_frames=0,
        gas_pressure_pa=gas_pa,
        abort_reason=row.cell("abort_reason") or None,
        gas_force_n=gas_force_n,
        gas_force_source=gas_force_source,
        target_velocity_m_s=target_velocity_m_s,
        reversal_accel_m_s2=reversal_accel_m_s2,
    )
    return ImportedTest(meta, block)


def _setting(row: _Row, opts: ImportOptions) -> tuple[int, int, float, float]:
    """Clicks, gas clicks, frequency and amplitude: numbers, not negative, plausible."""
    clicks = row.whole("clicks")
    gas = row.whole("gas_clicks") if row.cell("gas_clicks") else opts.gas_clicks
    for name, value in (("clicks", clicks), ("gas_clicks", gas)):
        if value < 0:
            raise RecordingError(f"{row.where(name)}: {value} must not be negative")
    freq = row.number("frequency_hz", positive=True)
    amp = row.number("amplitude_m")
    settings: tuple[tuple[str, float, float], ...] = (
        ("clicks", clicks, MAX_CLICKS),
        ("gas_clicks", gas, MAX_CLICKS),
        ("frequency_hz", freq, MAX_FREQUENCY_HZ),
        ("amplitude_m", amp, MAX_AMPLITUDE_M),
    )
    for name, setting, limit in settings:
        where = row.where(name) if name in row.cols else f"{row.manifest} (--gas-clicks)"
        check_setting(where, name, setting, limit)
    return clicks, gas, freq, amp


def _sample_rate(row: _Row, opts: ImportOptions, path: Path, block: SampleBlock) -> float:
    """The manifest's sample rate, else --sample-rate-hz, else 1 / the median time step."""
    if row.cell("sample_rate_hz"):
        rate = row.number("sample_rate_hz", positive=True)
    elif opts.sample_rate_hz is not None:
        rate = opts.sample_rate_hz
    elif len(block) >= 2:
        rate = float(f"{1.0 / float(np.median(np.diff(block.t_s))):.6g}")
    else:
        raise RecordingError(f"{path}: one sample; give the sample rate (--sample-rate-hz)")
    check_setting(str(path), "sample rate (Hz)", rate, MAX_SAMPLE_RATE_HZ)
    return rate


def _warn_amplitude(path: Path, block: SampleBlock, amp: float) -> None:
    """A sine whose data swing a hundred times more or less than its amplitude: said, not
    refused (the manifest or the data may be in another unit)."""
    if amp > 0 and len(block):
        top, bottom = float(block.displacement_m.max()), float(block.displacement_m.min())
        peak = (top - bottom) / 2
        if peak > 100 * amp or peak < amp / 100:
            print(
                f"warning: {path}: data swings ±{peak:.3g} m, the manifest says "
                f"amplitude_m {amp:g} (a unit mix-up?)",
                file=sys.stderr,
            )


def _adjusters(row: _Row) -> dict[str, int]:
    """A damper with several adjusters: each one's clicks, from its column clicks_NAME."""
    named: dict[str, int] = {}
    for j, h in enumerate(row.table.header):
        if h.startswith(ADJUSTER_PREFIX) and len(h) > len(ADJUSTER_PREFIX):
            value = _int_cell(row.table, row.i, j)
            if value < 0:
                raise RecordingError(f"{row.table.where(row.i, j)}: {value} must not be negative")
            check_setting(row.table.where(row.i, j), h, value, MAX_CLICKS)
            named[h[len(ADJUSTER_PREFIX) :]] = value
    return named


def _extra(row: _Row, file_name: str, places: str) -> dict[str, str]:
    """The columns no TestMeta field takes, kept as they are; and the data file's name and
    decimals, which export writes back."""
    cells = row.table.rows[row.i]
    extra = {
        h: cells[j].strip()
        for j, h in enumerate(row.table.header)
        if h not in MANIFEST_KNOWN
        and h not in (SOURCE_KEY, DECIMALS_KEY)
        and not h.startswith(ADJUSTER_PREFIX)
    }
    extra[SOURCE_KEY] = file_name
    if places:
        extra[DECIMALS_KEY] = places
    return extra


def _stroke(row: _Row, motion: str) -> tuple[float | None, float | None]:
    """A constant-velocity test's speed and reversal acceleration (export writes them)."""
    target, accel = (
        row.number(name, positive=True) if row.cell(name) else None
        for name in ("target_velocity_m_s", "reversal_accel_m_s2")
    )
    if motion in ("triangle", "trapezoid") and target is None:
        where = row.where("motion" if "motion" in row.cols else "file")
        raise RecordingError(f"{where}: a {motion} test needs its target_velocity_m_s column")
    return target, accel


def _gas_force(row: _Row) -> tuple[float | None, str | None]:
    """The manifest's gas force of a test (export writes the recording's), with its source:
    a number alone is taken as measured."""
    if not row.cell("gas_force_n"):
        return None, None
    value = row.number("gas_force_n")
    source = row.cell("gas_force_source") or "measured"
    if source not in GAS_FORCE_SOURCES:
        raise RecordingError(
            f"{row.where('gas_force_source')}: {source!r} is not one of "
            f"{', '.join(GAS_FORCE_SOURCES)}"
        )
    return value, source


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
