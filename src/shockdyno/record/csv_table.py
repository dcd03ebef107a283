"""A dyno's data CSV read as samples: columns by name, units, ISO or numeric time, the
file size and line length bounded, each channel's decimal places kept (docs/csv.md).
Errors name the file, the line and the column."""

from __future__ import annotations

import csv
import math
import stat
import sys
from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import IO, Protocol

import numpy as np
from numpy.typing import NDArray

from shockdyno.errors import RecordingError
from shockdyno.record.plausible import (
    check_samples,
)
from shockdyno.samples import SampleBlock
from shockdyno.units import M_PER_IN
from shockdyno.units import N_PER_LBF as LBF_N


class _Rows(Protocol):
    """What csv.reader gives: rows of text, and the line the last one ended on."""

    line_num: int

    def __iter__(self) -> Iterator[list[str]]: ...


LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "in": M_PER_IN}
FORCE_UNITS = {"N": 1.0, "kN": 1e3, "lbf": LBF_N}
TIME_UNITS = ("auto", "s", "ms", "iso")
TEMPERATURE_UNITS = ("C", "F")
MOTIONS = ("sine", "triangle", "trapezoid", "imported")
VELOCITY_COLUMN = "velocity_m_s"  # written by export; read only for its decimal places
DECIMALS_KEY = "csv_decimals"  # TestMeta.extra key: "time_s=3,force_N=2": fixed decimal places


@dataclass(frozen=True)
class ImportOptions:
    """How `record import` reads a manifest and its data CSVs: the column names and their units
    (converted to SI on import), the sample rate and motion where the manifest has none, the gas
    clicks, the delimiter, metadata to store, whether data files may lie outside the manifest's
    folder, and the largest file read."""

    time_column: str = "time_s"
    time_unit: str = "auto"  # numbers in seconds, or ISO 8601 date-times; see TIME_UNITS
    displacement_column: str = "displacement_m"
    displacement_unit: str = "m"
    force_column: str = "force_N"
    force_unit: str = "N"
    temperature_column: str | None = None  # None: "temperature_C" when the file has it
    temperature_unit: str = "C"
    sample_rate_hz: float | None = None  # None: manifest column, else 1 / median time step
    motion: str | None = None  # None: manifest column, else "sine"
    gas_clicks: int = 0  # when the manifest has no gas_clicks column
    delimiter: str = ","
    metadata: dict[str, str] = field(default_factory=dict)
    allow_outside: bool = False  # data files may lie outside the manifest's folder
    max_file_bytes: int = 1 << 30  # a larger data file is refused before it is read

    def check(self) -> None:
        """RecordingError naming the option when a unit, motion, sample rate, gas clicks or
        delimiter is not one the import knows."""
        for name, value, allowed in (
            ("time unit", self.time_unit, TIME_UNITS),
            ("displacement unit", self.displacement_unit, tuple(LENGTH_UNITS)),
            ("force unit", self.force_unit, tuple(FORCE_UNITS)),
            ("temperature unit", self.temperature_unit, TEMPERATURE_UNITS),
        ):
            if value not in allowed:
                raise RecordingError(f"{name} {value!r} is not one of {', '.join(allowed)}")
        if self.motion is not None and self.motion not in MOTIONS:
            raise RecordingError(f"motion {self.motion!r} is not one of {', '.join(MOTIONS)}")
        if self.sample_rate_hz is not None and not (
            math.isfinite(self.sample_rate_hz) and self.sample_rate_hz > 0
        ):
            raise RecordingError(f"sample rate {self.sample_rate_hz} Hz must be positive")
        if self.gas_clicks < 0:
            raise RecordingError(f"gas clicks {self.gas_clicks} must not be negative")
        if len(self.delimiter) != 1:
            raise RecordingError(f"delimiter {self.delimiter!r} must be one character")


def _check_file(path: Path, max_bytes: int) -> int:
    """Refuse, before reading, anything but a regular file of at most max_bytes: a device
    such as /dev/zero or a mistaken multi-gigabyte file must not exhaust memory."""
    try:
        st = path.stat()
    except FileNotFoundError:
        raise RecordingError(f"{path}: no such file") from None
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise RecordingError(f"{path}: not a regular file")
    if st.st_size > max_bytes:
        raise RecordingError(
            f"{path}: {st.st_size / 1e6:.0f} MB is more than the {max_bytes / 1e6:.0f} MB "
            "allowed for one file (--max-file-mb)"
        )
    return st.st_size


def _bounded_lines(fh: IO[str], path: Path, max_chars: int) -> Iterator[str]:
    """The file's lines as read (never the whole text at once: peak memory stays with the
    converted columns), refused if the file grows past its bound while being read."""
    seen = 0
    for line in fh:
        seen += len(line)
        if seen > max_chars:
            raise RecordingError(f"{path}: grew beyond {max_chars / 1e6:.0f} MB while being read")
        yield line


def _places(v: str) -> int:
    """Decimal places written in a number cell (-1: exponent notation)."""
    if "e" in v or "E" in v:
        return -1
    dot = v.find(".")
    return 0 if dot < 0 else len(v) - dot - 1


class CsvTable:
    """A CSV file's header and rows, with the line number of each row (for error messages).

    With `columns` (name -> "number", "number_or_empty", "time", "time_iso"), only those
    columns are kept, converted while reading (a data file: numbers in arrays of 8 bytes per
    cell instead of Python strings of ~55, so peak memory stays near 3x the file). Without
    it every row is kept as strings (the manifest).
    """

    def __init__(
        self,
        path: Path,
        delimiter: str,
        max_bytes: int = 1 << 30,
        columns: dict[str, str] | None = None,
    ) -> None:
        self.path = path
        _check_file(path, max_bytes)
        try:
            with path.open(encoding="utf-8-sig", newline="") as fh:
                self._read(fh, delimiter, max_bytes, columns)
        except UnicodeDecodeError as exc:
            raise RecordingError(f"{path}: cannot read: {exc}") from None
        except OSError as exc:
            raise RecordingError(f"{path}: cannot read: {exc.strerror or exc}") from None

    def _read(
        self, fh: IO[str], delimiter: str, max_bytes: int, columns: dict[str, str] | None
    ) -> None:
        path = self.path
        reader = csv.reader(_bounded_lines(fh, path, max_bytes), delimiter=delimiter)
        header = next(reader, None)
        if header is None or not any(h.strip() for h in header):
            raise RecordingError(f"{path}:1: empty file, expected a header line")
        self.header = [h.strip() for h in header]
        self.rows: list[list[str]] = []
        self.lines: list[int] | array[int] = []
        # Decimal places of a numeric column when every cell has the same (export keeps them)
        self.decimals: dict[int, int | None] = {}
        self.values: dict[int, NDArray[np.float64]] = {}
        self.texts: dict[int, list[str]] = {}
        self.count = 0
        wanted = {self.column(name): kind for name, kind in (columns or {}).items()}
        try:
            if columns is None:
                self._keep_rows(reader)
            else:
                self._convert(reader, wanted)
        except csv.Error as exc:
            raise RecordingError(f"{path}:{reader.line_num}: {exc}") from exc

    def _check_width(self, row: list[str], line: int) -> bool:
        if not any(c.strip() for c in row):
            return False
        if len(row) != len(self.header):
            raise RecordingError(
                f"{self.path}:{line}: {len(row)} fields, the header has {len(self.header)}"
            )
        return True

    def _keep_rows(self, reader: _Rows) -> None:
        lines: list[int] = []
        for row in reader:
            if self._check_width(row, reader.line_num):
                self.rows.append(row)
                lines.append(reader.line_num)
        self.lines = lines
        self.count = len(self.rows)

    def _convert(self, reader: _Rows, wanted: dict[int, str]) -> None:
        lines = array("i")
        nums = {c: array("d") for c, k in wanted.items() if k != "time_iso"}
        texts: dict[int, list[str]] = {c: [] for c, k in wanted.items() if k == "time_iso"}
        places: dict[int, set[int]] = {c: set() for c in nums}
        for row in reader:
            if not self._check_width(row, reader.line_num):
                continue
            lines.append(reader.line_num)
            for c, out in nums.items():
                v = row[c].strip()
                if v == "" and wanted[c] == "number_or_empty":
                    out.append(math.nan)
                    continue
                try:
                    x = float(v)
                except ValueError:
                    raise RecordingError(
                        f"{self._at(reader.line_num, c)}: {v!r} is not a number"
                    ) from None
                if not math.isfinite(x):
                    raise RecordingError(
                        f"{self._at(reader.line_num, c)}: {v!r} is not a finite number"
                    )
                out.append(x)
                if len(places[c]) < 2:
                    places[c].add(_places(v))
            for c, strings in texts.items():
                strings.append(row[c].strip())
        self.lines = lines
        self.count = len(lines)
        for c, out in nums.items():
            self.values[c] = np.frombuffer(out, np.float64) if len(out) else np.zeros(0)
            p = places[c]
            self.decimals[c] = p.pop() if len(p) == 1 and -1 not in p else None
        self.texts = texts

    def column(self, name: str) -> int:
        """The index of the named column; RecordingError listing the file's columns when it has
        none."""
        try:
            return self.header.index(name)
        except ValueError:
            have = ", ".join(self.header)
            raise RecordingError(f"{self.path}:1: no column {name!r} (columns: {have})") from None

    def _at(self, line: int, col: int) -> str:
        return f"{self.path}:{line}: column {self.header[col]!r}"

    def where(self, row: int, col: int) -> str:
        """`FILE:LINE: column 'NAME'` of a row's cell, for an error message."""
        return self._at(int(self.lines[row]), col)

    def cells(self, col: int) -> Iterator[tuple[int, str]]:
        """(row, text) of every cell of a column kept as text, stripped."""
        if col in self.texts:
            yield from enumerate(self.texts[col])
            return
        for i, row in enumerate(self.rows):
            yield i, row[col].strip()

    def numbers(self, col: int) -> NDArray[np.float64]:
        """A converted column's values (NaN where empty, for `number_or_empty`)."""
        return self.values[col]


def _peek(path: Path, delimiter: str, column: str) -> tuple[list[str], str]:
    """The header and the first data cell of a column (to tell numbers from date-times),
    reading only the start of a file already checked to be a bounded regular file."""
    try:
        with path.open(encoding="utf-8-sig", newline="") as fh:
            reader = csv.reader(fh, delimiter=delimiter)
            header = [h.strip() for h in next(reader, [])]
            for row in reader:
                if any(c.strip() for c in row):
                    col = header.index(column) if column in header else len(row)
                    return header, row[col].strip() if col < len(row) else ""
            return header, ""
    except (OSError, UnicodeDecodeError, csv.Error):
        return [], ""  # the full read reports the problem properly


def _scaled(values: NDArray[np.float64], factor: float) -> NDArray[np.float64]:
    """Unit conversion in place (the array is this import's own): no copy per column."""
    if factor != 1.0:
        values *= factor
    return values


def _times(table: CsvTable, col: int, unit: str) -> tuple[NDArray[np.float64], str]:
    if unit in ("s", "ms"):
        return _scaled(table.numbers(col), 1e-3 if unit == "ms" else 1.0), unit
    stamps: list[datetime] = []
    for i, v in table.cells(col):
        try:
            stamps.append(datetime.fromisoformat(v))
        except ValueError:
            raise RecordingError(f"{table.where(i, col)}: {v!r} is not an ISO date-time") from None
    t = np.empty(len(stamps))
    for i, ts in enumerate(stamps):
        try:
            t[i] = (ts - stamps[0]).total_seconds()
        except TypeError:
            raise RecordingError(
                f"{table.where(i, col)}: mixes date-times with and without a time zone"
            ) from None
    return t, unit


def read_data_csv(path: Path, opts: ImportOptions) -> tuple[SampleBlock, str]:
    """One test's samples in SI units, and the decimal places of its columns (DECIMALS_KEY).

    seq is the sample index: imported data has no DAQ counter.
    """
    _check_file(path, opts.max_file_bytes)
    header, first = _peek(path, opts.delimiter, opts.time_column)
    unit = opts.time_unit
    if unit == "auto":
        try:
            float(first)
            unit = "s"
        except ValueError:
            unit = "iso"
    temp_name = opts.temperature_column
    if temp_name is None and "temperature_C" in header:
        temp_name = "temperature_C"
    columns = {
        opts.time_column: "time_iso" if unit == "iso" else "number",
        opts.displacement_column: "number",
        opts.force_column: "number",
    }
    if temp_name is not None:
        columns[temp_name] = "number_or_empty"
    # An exported velocity is checked as a number and its places kept for the next export;
    # its values are not used (the analysis takes its own derivative).
    if VELOCITY_COLUMN in header:
        columns[VELOCITY_COLUMN] = "number_or_empty"
    table = CsvTable(path, opts.delimiter, opts.max_file_bytes, columns)
    if not table.count:
        raise RecordingError(f"{path}:2: no data rows")
    t_col = table.column(opts.time_column)
    x_col = table.column(opts.displacement_column)
    f_col = table.column(opts.force_column)
    t, t_unit = _times(table, t_col, unit)
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise RecordingError(f"{table.where(i, t_col)}: time does not increase")
    with np.errstate(over="ignore"):  # an overflow to inf is refused by check_samples
        x = _scaled(table.numbers(x_col), LENGTH_UNITS[opts.displacement_unit])
        force = _scaled(table.numbers(f_col), FORCE_UNITS[opts.force_unit])
    # Only power-of-ten unit changes keep a fixed number of decimal places meaningful
    shifts = [
        ("time_s", t_col, {"s": 0, "ms": 3}.get(t_unit)),
        ("displacement_m", x_col, {"m": 0, "mm": 3}.get(opts.displacement_unit)),
        ("force_N", f_col, {"N": 0, "kN": -3}.get(opts.force_unit)),
    ]
    if temp_name is None:
        temp = np.full(t.size, math.nan)
    else:
        temp_col = table.column(temp_name)
        temp = table.numbers(temp_col)
        if opts.temperature_unit == "F":
            temp = (temp - 32.0) * (5.0 / 9.0)
        shifts.append(("temperature_C", temp_col, 0 if opts.temperature_unit == "C" else None))
    if VELOCITY_COLUMN in header:
        shifts.append((VELOCITY_COLUMN, table.column(VELOCITY_COLUMN), 0))
    places = []
    for name, col, shift in shifts:
        d = table.decimals.get(col)
        if d is not None and shift is not None:
            places.append(f"{name}={max(0, d + shift)}")
    for warning in check_samples(str(path), x, force, temp):
        print(f"warning: {warning}", file=sys.stderr)
    n = t.size
    block = SampleBlock(np.arange(n, dtype=np.int64), t, x, force, temp, np.zeros(n, np.uint16))
    return block, ",".join(places)
