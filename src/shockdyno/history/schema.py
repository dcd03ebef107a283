"""The history database's layout, its version, and the steps from each version to the next.

The file is SQLite (Python's own `sqlite3`: nothing to install, no server, one file that
any SQLite or DuckDB client opens). Its version is `PRAGMA user_version`. A new database
is built by running every step from 0, so the steps an older file takes are the ones
every new file took: a migration is never code that runs only on someone else's machine.

Opening a file of an older version migrates it in one transaction (all steps or none),
after copying it beside itself (`history.sqlite.v1.bak`); a file of a newer version than
this code knows is refused in one line (upgrade shockdyno), never changed.

- **1**: `recordings` (a recording's identity and metadata, one gas force), `results`
  (a fit or a diagnosis of it, keyed by the options that shape it), `areas` (a fit's bleed
  areas per click), `parameters` (a fit's globals and term parameters, a diagnosis's
  calibrated spec values).
- **2**: the gas force with its uncertainty and source, per gas setting (`gas_forces`;
  report/gas.py gives estimates a σ and may refuse them): version 1's single
  `recordings.gas_force_n` moves there, at the recording's first gas setting, source
  `unknown` (version 1 did not say), and leaves `recordings`; an index on the damper id.
"""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

from shockdyno.errors import ConfigError

_V1 = """
        CREATE TABLE recordings (
            sha256 TEXT PRIMARY KEY,
            file TEXT NOT NULL,
            damper_id TEXT NOT NULL DEFAULT '',
            operator TEXT NOT NULL DEFAULT '',
            recorded_utc TEXT NOT NULL,
            rig TEXT NOT NULL DEFAULT '',
            notes TEXT NOT NULL DEFAULT '',
            clicks TEXT NOT NULL DEFAULT '',
            gas_clicks TEXT NOT NULL DEFAULT '',
            n_tests INTEGER NOT NULL DEFAULT 0,
            gas_force_n REAL,
            added_utc TEXT NOT NULL
        );
        CREATE TABLE results (
            id INTEGER PRIMARY KEY,
            sha256 TEXT NOT NULL REFERENCES recordings(sha256),
            kind TEXT NOT NULL,
            options TEXT NOT NULL,
            made_utc TEXT NOT NULL,
            result_file TEXT NOT NULL DEFAULT '',
            version TEXT NOT NULL DEFAULT '',
            e_t REAL,
            e_t_before REAL,
            physics TEXT NOT NULL DEFAULT '',
            verdict TEXT NOT NULL DEFAULT '',
            UNIQUE (sha256, kind, options)
        );
        CREATE TABLE areas (
            result_id INTEGER NOT NULL REFERENCES results(id) ON DELETE CASCADE,
            clicks INTEGER NOT NULL,
            gas_clicks INTEGER NOT NULL,
            a_bc_m2 REAL,
            a_bt_m2 REAL,
            a_bc_sd_m2 REAL,
            a_bt_sd_m2 REAL,
            PRIMARY KEY (result_id, clicks, gas_clicks)
        );
        CREATE TABLE parameters (
            result_id INTEGER NOT NULL REFERENCES results(id) ON DELETE CASCADE,
            name TEXT NOT NULL,
            value REAL,
            sd REAL,
            unit TEXT NOT NULL DEFAULT '',
            PRIMARY KEY (result_id, name)
        );
"""

_V2 = """
        CREATE TABLE gas_forces (
            sha256 TEXT NOT NULL REFERENCES recordings(sha256) ON DELETE CASCADE,
            gas_clicks INTEGER NOT NULL,
            gas_force_n REAL,
            gas_force_sd_n REAL,
            source TEXT NOT NULL,
            PRIMARY KEY (sha256, gas_clicks)
        );
        INSERT INTO gas_forces (sha256, gas_clicks, gas_force_n, gas_force_sd_n, source)
            SELECT sha256,
                   CAST(COALESCE(NULLIF(substr(gas_clicks, 1, instr(gas_clicks || ',', ',') - 1),
                                        ''), '0') AS INTEGER),
                   gas_force_n, NULL, 'unknown'
            FROM recordings WHERE gas_force_n IS NOT NULL;
        CREATE TABLE recordings_v2 (
            sha256 TEXT PRIMARY KEY,
            file TEXT NOT NULL,
            damper_id TEXT NOT NULL DEFAULT '',
            operator TEXT NOT NULL DEFAULT '',
            recorded_utc TEXT NOT NULL,
            rig TEXT NOT NULL DEFAULT '',
            notes TEXT NOT NULL DEFAULT '',
            clicks TEXT NOT NULL DEFAULT '',
            gas_clicks TEXT NOT NULL DEFAULT '',
            n_tests INTEGER NOT NULL DEFAULT 0,
            added_utc TEXT NOT NULL
        );
        INSERT INTO recordings_v2
            SELECT sha256, file, damper_id, operator, recorded_utc, rig, notes, clicks,
                   gas_clicks, n_tests, added_utc
            FROM recordings;
        DROP TABLE recordings;
        ALTER TABLE recordings_v2 RENAME TO recordings;
        CREATE INDEX recordings_by_damper ON recordings (damper_id, recorded_utc);
"""

# Step n takes a database of version n - 1 to version n: SQL run statement by statement
# inside the migration's one transaction (sqlite3's executescript would commit).
STEPS: dict[int, str] = {1: _V1, 2: _V2}
VERSION = max(STEPS)


def version_of(db: sqlite3.Connection) -> int:
    """The history database's schema version (SQLite's `user_version`; 0: a new file)."""
    return int(db.execute("PRAGMA user_version").fetchone()[0])


def migrate(db: sqlite3.Connection, to: int = VERSION) -> int:
    """Run the steps from the file's version up to `to`, in one transaction; returns the
    version it had."""
    had = version_of(db)
    if had >= to:
        return had
    db.execute("PRAGMA foreign_keys = OFF")  # a table rebuilt in a step is re-pointed whole
    try:
        db.execute("BEGIN IMMEDIATE")
        for n in range(had + 1, to + 1):
            for statement in _statements(STEPS[n]):
                db.execute(statement)
            db.execute(f"PRAGMA user_version = {n}")
        db.execute("COMMIT")
    except BaseException:
        db.execute("ROLLBACK")
        raise
    finally:
        db.execute("PRAGMA foreign_keys = ON")
    return had


def _statements(script: str) -> list[str]:
    out, buf = [], ""
    for line in script.splitlines(keepends=True):
        buf += line
        if sqlite3.complete_statement(buf):
            if buf.strip():
                out.append(buf.strip())
            buf = ""
    if buf.strip():
        out.append(buf.strip())
    return out


def open_db(path: Path) -> sqlite3.Connection:
    """The history database at `path`, created or migrated to VERSION (module docstring)."""
    new = not path.exists()
    if new:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError(
                f"history {path}: cannot create its folder ({exc.strerror})"
            ) from None
    elif not _is_sqlite(path):
        raise ConfigError(f"history {path}: not an SQLite database; move it away or name another")
    db = sqlite3.connect(path, timeout=30.0, isolation_level=None)
    try:
        db.execute("PRAGMA foreign_keys = ON")
        found = version_of(db)
        if found > VERSION:
            raise ConfigError(
                f"history {path}: written by a newer shockdyno (schema {found}; this one knows "
                f"up to {VERSION}); upgrade shockdyno to use it (the file is left as it is)"
            )
        if found < VERSION:
            if not new and found > 0:
                shutil.copy2(path, path.with_name(f"{path.name}.v{found}.bak"))
            migrate(db)
    except sqlite3.DatabaseError as exc:
        db.close()
        raise ConfigError(f"history {path}: {exc}") from None
    except BaseException:
        db.close()
        raise
    return db


def _is_sqlite(path: Path) -> bool:
    try:
        with path.open("rb") as fh:
            head = fh.read(16)
    except OSError as exc:
        raise ConfigError(f"history {path}: cannot read it ({exc.strerror})") from None
    return head == b"SQLite format 3\x00" or head == b""
