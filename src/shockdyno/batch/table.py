"""The batch's results table: DIR/results.parquet and DIR/results.csv, a row a recording
and command.

The table accumulates: a row is keyed by (name, kind), the recording's result name in DIR
and the command (`fit`, `diagnose`, `report`). A batch replaces the rows of the keys it
runs and keeps every other row, so `batch fit` then `batch diagnose --fit DIR` into the
same DIR leave both (issue 47.2: the second used to rewrite the table with its own rows
only). Rows are sorted by name, then kind in the order of KINDS.

Parquet by pyarrow: it is the reference implementation the rest of the ecosystem (pandas,
polars, DuckDB, Spark) reads and writes, it writes a typed schema without pandas, and one
wheel serves both this file and the CSV. Both files are replaced whole (write beside,
then rename), so an interrupted batch leaves the last complete table.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

from shockdyno import __version__
from shockdyno.errors import ConfigError

KINDS = ("fit", "diagnose", "report")  # the commands, in the order a row's name lists them


@dataclass
class Row:
    """One line of results.parquet / results.csv: its one definition, which a batch task
    fills (batch/jobs.py), this module writes and reads, and the command prints."""

    path: str
    name: str
    sha256: str
    kind: str
    status: str  # done | skipped | failed
    error: str = ""
    damper_id: str = ""
    clicks: str = ""
    frequencies_hz: str = ""
    e_t_before: float | None = None
    e_t_after: float | None = None
    physics: str = ""
    calibration: str = ""
    result: str = ""
    # `batch report`: what the page computed from the fit that its saved model forces did
    # not hold, as `report` says it (fit/forces.computed_note); "" when it read them all.
    note: str = ""
    wall_s: float = 0.0
    version: str = __version__


# The columns, in the table's order, and their Parquet types: Row's fields.
COLUMNS: list[tuple[str, str]] = [
    (f.name, "string" if f.type == "str" else "float64") for f in fields(Row)
]


# pyarrow is imported by the functions that write or read the table: at the top it would
# add 40-70 ms CPU to every command's start-up (pyarrow, .parquet, .csv; measured).


def _schema() -> Any:  # Any: a pyarrow.Schema (pyarrow has no type information)
    # here, as below: pyarrow costs 35-41 ms at every command's start (measured)
    import pyarrow as pa

    types = {"string": pa.string(), "float64": pa.float64()}
    return pa.schema([(name, types[t]) for name, t in COLUMNS])


def _replace(target: Path, write: Callable[[str], object]) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_table(out_dir: Path, rows: Sequence[Row]) -> None:
    # here: see _schema
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    table = pa.Table.from_pylist([asdict(r) for r in rows], schema=_schema())
    _replace(out_dir / "results.parquet", lambda p: pq.write_table(table, p))
    _replace(out_dir / "results.csv", lambda p: pacsv.write_csv(table, p))


def read_table(out_dir: Path) -> list[Row]:
    """The table's rows; a column this version does not know is left out, one it added
    since (or a null) takes Row's default."""
    # here: see _schema
    import pyarrow.parquet as pq

    known = {f.name for f in fields(Row)}
    return [
        Row(**{k: v for k, v in r.items() if k in known and v is not None})
        for r in pq.read_table(out_dir / "results.parquet").to_pylist()
    ]


def earlier_rows(out_dir: Path) -> list[Row]:
    """The rows a DIR already holds (none without a table); a table that cannot be read
    is refused in one line before any work, never overwritten."""
    if not (out_dir / "results.parquet").exists():
        return []
    try:
        return read_table(out_dir)
    except Exception as exc:  # pyarrow raises its own kinds for a damaged file
        raise ConfigError(
            f"--out {out_dir}: results.parquet cannot be read ({type(exc).__name__}); move it "
            "away (the results beside it are kept) and run again"
        ) from None


def merged(earlier: Sequence[Row], rows: Sequence[Row]) -> list[Row]:
    """The earlier rows with this run's rows in place of those of the same (name, kind)."""
    by_key = {(r.name, r.kind): r for r in earlier}
    by_key.update({(r.name, r.kind): r for r in rows})
    order = {kind: i for i, kind in enumerate(KINDS)}
    return sorted(by_key.values(), key=lambda r: (r.name, order.get(r.kind, 99)))
