"""What the history holds, typed, and the only code that reads or writes its tables.

A recording is known by its SHA-256 (record/identity.py), so the same file fitted twice,
or fitted and diagnosed, is one recording with two results; a result is replaced by a
later one of the same kind and options (the same fit run again), and kept beside one of
other options (another `--terms`).
"""

from __future__ import annotations

import json
import math
import sqlite3
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from shockdyno.errors import ConfigError
from shockdyno.history.schema import open_db
from shockdyno.schema import finite_or_none


@dataclass(frozen=True)
class GasEntry:
    """The static gas force (N) of one gas setting of a recording, its sd (N), and where it came
    from (measured, estimated, given, refused, unknown)."""

    gas_clicks: int
    gas_force_n: float | None  # None: not known (an estimate refused)
    sd_n: float | None
    source: str  # measured | estimated | given | refused | unknown


@dataclass(frozen=True)
class RecordingEntry:
    """One recording in the history, known by its SHA-256: file name, damper, operator, when it
    was recorded (UTC), rig, notes, the clicks and gas clicks it swept, its test count and gas
    forces."""

    sha256: str
    file: str
    damper_id: str
    operator: str
    recorded_utc: str  # ISO 8601, from the recording's metadata, else the file's time
    rig: str = ""
    notes: str = ""
    clicks: str = ""  # "0,3,6"
    gas_clicks: str = ""
    n_tests: int = 0
    gas: tuple[GasEntry, ...] = ()


@dataclass(frozen=True)
class AreaEntry:
    """A fit's bleed areas at one setting (m², A_bc compression, A_bt rebound), with their sd."""

    clicks: int
    gas_clicks: int
    a_bc_m2: float | None
    a_bt_m2: float | None
    a_bc_sd_m2: float | None = None
    a_bt_sd_m2: float | None = None


@dataclass(frozen=True)
class ParameterEntry:
    """A fitted number by name (a spec global or a term's qualified parameter), its sd and unit
    (SI)."""

    name: str  # a spec global (friction_n), a term's (friction.breakaway_n)
    value: float | None
    sd: float | None = None
    unit: str = ""


@dataclass(frozen=True)
class ResultEntry:
    """One fit or diagnosis of a recording: its options, when it was made (UTC), its file and
    shockdyno version, E_t (before and after, for a diagnosis), the physics, the verdict, areas
    and parameters."""

    kind: str  # "fit" | "diagnose"
    options: dict[str, object]  # a JSON object: stored as text, compared whole
    made_utc: str
    result_file: str = ""
    version: str = ""
    e_t: float | None = None  # fit: mean E_t of the proposed model; diagnose: after
    e_t_before: float | None = None  # diagnose: before
    physics: str = ""  # fit: the terms fitted; diagnose: the physics claimed
    verdict: str = ""  # diagnose: its verdict in words
    areas: tuple[AreaEntry, ...] = ()
    parameters: tuple[ParameterEntry, ...] = ()


@dataclass
class Visit:
    """One recording of a damper with its results, as `history` shows it."""

    recording: RecordingEntry
    results: list[ResultEntry] = field(default_factory=list)

    def latest(self, kind: str) -> ResultEntry | None:
        """The newest result of that kind (`fit`, `diagnose`), or None."""
        found = [r for r in self.results if r.kind == kind]
        return max(found, key=lambda r: r.made_utc) if found else None


@contextmanager
def history(path: Path) -> Iterator[sqlite3.Connection]:
    """The database at `path`, closed after; any SQLite error (a lock held past the 30 s
    timeout, a damaged file) is one ConfigError line naming it."""
    db = open_db(path)
    try:
        yield db
    except sqlite3.Error as exc:
        raise ConfigError(f"history {path}: {exc}") from None
    finally:
        db.close()


def add(path: Path, rec: RecordingEntry, result: ResultEntry) -> None:
    """Store a recording (its identity and metadata refreshed) and one result of it, in one
    transaction: the result of the same recording, kind and options before is replaced."""
    options = json.dumps(result.options, sort_keys=True)
    with history(path) as db:
        db.execute("BEGIN IMMEDIATE")
        try:
            db.execute(
                """INSERT INTO recordings (sha256, file, damper_id, operator, recorded_utc, rig,
                       notes, clicks, gas_clicks, n_tests, added_utc)
                   VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)
                   ON CONFLICT (sha256) DO UPDATE SET file = excluded.file,
                       damper_id = excluded.damper_id, operator = excluded.operator,
                       recorded_utc = excluded.recorded_utc, rig = excluded.rig,
                       notes = excluded.notes, clicks = excluded.clicks,
                       gas_clicks = excluded.gas_clicks, n_tests = excluded.n_tests""",
                (rec.sha256, rec.file, rec.damper_id, rec.operator, rec.recorded_utc, rec.rig,
                 rec.notes, rec.clicks, rec.gas_clicks, rec.n_tests, result.made_utc),
            )  # fmt: skip
            db.execute("DELETE FROM gas_forces WHERE sha256 = ?", (rec.sha256,))
            db.executemany(
                "INSERT INTO gas_forces VALUES (?, ?, ?, ?, ?)",
                [(rec.sha256, g.gas_clicks, finite_or_none(g.gas_force_n), finite_or_none(g.sd_n),
                  g.source) for g in rec.gas],
            )  # fmt: skip
            db.execute(
                "DELETE FROM results WHERE sha256 = ? AND kind = ? AND options = ?",
                (rec.sha256, result.kind, options),
            )
            cur = db.execute(
                """INSERT INTO results (sha256, kind, options, made_utc, result_file, version,
                       e_t, e_t_before, physics, verdict) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)""",
                (rec.sha256, result.kind, options, result.made_utc, result.result_file,
                 result.version, finite_or_none(result.e_t), finite_or_none(result.e_t_before),
                 result.physics, result.verdict),
            )  # fmt: skip
            rid = cur.lastrowid
            db.executemany(
                "INSERT INTO areas VALUES (?, ?, ?, ?, ?, ?, ?)",
                [(rid, a.clicks, a.gas_clicks, finite_or_none(a.a_bc_m2), finite_or_none(a.a_bt_m2),
                  finite_or_none(a.a_bc_sd_m2), finite_or_none(a.a_bt_sd_m2))
                 for a in result.areas],
            )  # fmt: skip
            db.executemany(
                "INSERT INTO parameters VALUES (?, ?, ?, ?, ?)",
                [
                    (rid, p.name, finite_or_none(p.value), finite_or_none(p.sd), p.unit)
                    for p in result.parameters
                ],
            )
            db.execute("COMMIT")
        except BaseException:
            db.execute("ROLLBACK")
            raise


def dampers(path: Path) -> list[tuple[str, int, str, str]]:
    """(damper id, recordings, first and last date) of every damper in the history."""
    with history(path) as db:
        rows = db.execute(
            """SELECT damper_id, COUNT(*), MIN(recorded_utc), MAX(recorded_utc)
               FROM recordings GROUP BY damper_id ORDER BY damper_id"""
        ).fetchall()
    return [(str(a), int(b), str(c), str(d)) for a, b, c, d in rows]


def visits(path: Path, damper_id: str) -> list[Visit]:
    """Every recording of the damper, oldest first, each with its results."""
    with history(path) as db:
        recs = db.execute(
            """SELECT sha256, file, damper_id, operator, recorded_utc, rig, notes, clicks,
                      gas_clicks, n_tests FROM recordings WHERE damper_id = ?
               ORDER BY recorded_utc, added_utc""",
            (damper_id,),
        ).fetchall()
        out = []
        for row in recs:
            gas = tuple(
                GasEntry(int(g), f, sd, str(src))
                for g, f, sd, src in db.execute(
                    """SELECT gas_clicks, gas_force_n, gas_force_sd_n, source FROM gas_forces
                       WHERE sha256 = ? ORDER BY gas_clicks""",
                    (row[0],),
                )
            )
            sha, file, damper, operator, when, rig, notes, clicks, gas_clicks, n = row
            visit = Visit(
                RecordingEntry(
                    sha, file, damper, operator, when, rig, notes, clicks, gas_clicks, int(n), gas
                )
            )
            for r in db.execute(
                """SELECT id, kind, options, made_utc, result_file, version, e_t, e_t_before,
                          physics, verdict FROM results WHERE sha256 = ? ORDER BY made_utc, id""",
                (row[0],),
            ).fetchall():
                areas = tuple(
                    AreaEntry(*a)
                    for a in db.execute(
                        """SELECT clicks, gas_clicks, a_bc_m2, a_bt_m2, a_bc_sd_m2, a_bt_sd_m2
                           FROM areas WHERE result_id = ? ORDER BY gas_clicks, clicks""",
                        (r[0],),
                    )
                )
                params = tuple(
                    ParameterEntry(*p)
                    for p in db.execute(
                        "SELECT name, value, sd, unit FROM parameters WHERE result_id = ? "
                        "ORDER BY name",
                        (r[0],),
                    )
                )
                kind, options, made, file_, version, e_t, e_t_before, physics, verdict = r[1:]
                visit.results.append(
                    ResultEntry(
                        kind,
                        json.loads(options),
                        made,
                        file_,
                        version,
                        e_t,
                        e_t_before,
                        physics,
                        verdict,
                        areas,
                        params,
                    )
                )
            out.append(visit)
    return out


def grown(visits: list[Visit]) -> tuple[list[Visit], int]:
    """The visits without the earlier readings of a recording that grew: a sweep stopped
    and resumed is one file (its first part's path and date) whose bytes, and so SHA-256,
    changed; a fit of it before the resume is kept in the database but not shown as a
    recording of its own. Returns the visits shown and how many were left out."""
    latest: dict[tuple[str, str], Visit] = {}
    for v in visits:
        key = (v.recording.file, v.recording.recorded_utc)
        if key not in latest or v.recording.n_tests >= latest[key].recording.n_tests:
            latest[key] = v
    kept = [v for v in visits if latest[(v.recording.file, v.recording.recorded_utc)] is v]
    return kept, len(visits) - len(kept)


def known(values: Sequence[float | None]) -> list[float]:
    """The finite values, without the unknown ones."""
    return [float(v) for v in values if v is not None and math.isfinite(v)]
