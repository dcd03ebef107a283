"""The batch's results table: DIR/results.parquet and DIR/results.csv, a row a recording.

Parquet by pyarrow: it is the reference implementation the rest of the ecosystem (pandas,
polars, DuckDB, Spark) reads and writes, it writes a typed schema without pandas, and one
wheel serves both this file and the CSV. Both files are replaced whole (write beside,
then rename), so an interrupted batch leaves the last complete table.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

COLUMNS: list[tuple[str, str]] = [
    ("path", "string"),
    ("name", "string"),
    ("sha256", "string"),
    ("kind", "string"),
    ("status", "string"),
    ("error", "string"),
    ("damper_id", "string"),
    ("clicks", "string"),
    ("frequencies_hz", "string"),
    ("e_t_before", "float64"),
    ("e_t_after", "float64"),
    ("physics", "string"),
    ("calibration", "string"),
    ("result", "string"),
    ("wall_s", "float64"),
    ("version", "string"),
]


def _schema() -> Any:
    import pyarrow as pa

    types = {"string": pa.string(), "float64": pa.float64()}
    return pa.schema([(name, types[t]) for name, t in COLUMNS])


def _replace(target: Path, write: Any) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_table(out_dir: Path, rows: list[dict[str, Any]]) -> None:
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    table = pa.Table.from_pylist(
        [{name: r.get(name) for name, _ in COLUMNS} for r in rows], schema=_schema()
    )
    _replace(out_dir / "results.parquet", lambda p: pq.write_table(table, p))
    _replace(out_dir / "results.csv", lambda p: pacsv.write_csv(table, p))


def read_table(out_dir: Path) -> list[dict[str, Any]]:
    import pyarrow.parquet as pq

    rows: list[dict[str, Any]] = pq.read_table(out_dir / "results.parquet").to_pylist()
    return rows
