"""The history database's versions: an older file is migrated (in one transaction, after a
backup) with its data, a newer one is refused untouched, a foreign file is refused."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from shockdyno.errors import ConfigError
from shockdyno.history import schema, store


def _version_1(path: Path) -> None:
    """A database as version 1 of this code left it: its layout, and a damper's rows."""
    db = sqlite3.connect(path, isolation_level=None)
    schema.migrate(db, to=1)
    db.execute(
        "INSERT INTO recordings VALUES ('aa11', 'before.mcap', 'S46-0421', 'jd', "
        "'2026-03-01T09:00:00Z', 'sim', '', '0,10,21', '2', 6, 231.4, '2026-03-01T10:00:00Z')"
    )
    db.execute(
        "INSERT INTO recordings VALUES ('bb22', 'old.mcap', 'S46-0421', 'jd', "
        "'2026-01-01T09:00:00Z', 'sim', '', '10', '', 3, NULL, '2026-01-01T10:00:00Z')"
    )
    db.execute(
        "INSERT INTO results VALUES (1, 'aa11', 'fit', '{}', '2026-03-01T10:00:00Z', "
        "'before.fit.json', '0.1.0', 0.004, NULL, 'sensor_lag', '')"
    )
    db.execute("INSERT INTO areas VALUES (1, 10, 2, 1.0e-5, 2.6e-6, 3e-9, 5e-10)")
    db.execute("INSERT INTO parameters VALUES (1, 'friction_n', 35.1, 0.1, 'N')")
    db.close()


def test_a_version_1_database_is_migrated_with_its_data_and_a_backup(tmp_path: Path) -> None:
    path = tmp_path / "history.sqlite"
    _version_1(path)
    visits = store.visits(path, "S46-0421")  # opening it migrates it
    db = sqlite3.connect(path)
    assert db.execute("PRAGMA user_version").fetchone()[0] == schema.VERSION == 2
    columns = [r[1] for r in db.execute("PRAGMA table_info(recordings)")]
    assert "gas_force_n" not in columns  # moved to gas_forces
    assert db.execute("SELECT * FROM gas_forces").fetchall() == [
        ("aa11", 2, 231.4, None, "unknown")
    ]
    assert db.execute("PRAGMA foreign_key_check").fetchall() == []
    db.close()
    # Oldest first, every row as it was: the recording, its fit, areas and parameters.
    assert [v.recording.file for v in visits] == ["old.mcap", "before.mcap"]
    (fit,) = visits[1].results
    assert (fit.kind, fit.e_t, fit.physics) == ("fit", 0.004, "sensor_lag")
    assert [(a.clicks, a.gas_clicks, a.a_bc_m2) for a in fit.areas] == [(10, 2, 1.0e-5)]
    assert [(p.name, p.value) for p in fit.parameters] == [("friction_n", 35.1)]
    assert visits[1].recording.gas[0].gas_force_n == 231.4
    # The file as it was, kept beside it.
    backup = tmp_path / "history.sqlite.v1.bak"
    old = sqlite3.connect(backup)
    assert old.execute("PRAGMA user_version").fetchone()[0] == 1
    assert old.execute("SELECT gas_force_n FROM recordings WHERE sha256 = 'aa11'").fetchone()
    old.close()
    # A second open finds it current: no second backup, nothing changed.
    backup.unlink()
    assert [v.recording.file for v in store.visits(path, "S46-0421")] == ["old.mcap", "before.mcap"]
    assert not backup.exists()


def test_a_migration_that_fails_leaves_the_version_1_file_as_it_was(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "history.sqlite"
    _version_1(path)
    broken = schema.STEPS[2].replace("DROP TABLE recordings;", "DROP TABLE no_such_table;")
    monkeypatch.setitem(schema.STEPS, 2, broken)
    with pytest.raises(ConfigError, match="no such table"):
        store.dampers(path)
    db = sqlite3.connect(path)
    assert db.execute("PRAGMA user_version").fetchone()[0] == 1
    assert db.execute("SELECT gas_force_n FROM recordings WHERE sha256='aa11'").fetchone() == (
        231.4,
    )
    assert "gas_forces" not in [r[0] for r in db.execute("SELECT name FROM sqlite_master")]
    db.close()


def test_a_newer_database_is_refused_and_left_alone(tmp_path: Path) -> None:
    path = tmp_path / "history.sqlite"
    db = sqlite3.connect(path)
    db.execute("CREATE TABLE future (x)")
    db.execute("PRAGMA user_version = 7")
    db.commit()
    db.close()
    before = path.read_bytes()
    with pytest.raises(ConfigError, match=r"newer shockdyno \(schema 7; this one knows up to 2\)"):
        store.dampers(path)
    assert path.read_bytes() == before


def test_a_file_that_is_not_a_database_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "history.sqlite"
    path.write_text("not a database\n")
    with pytest.raises(ConfigError, match="not an SQLite database"):
        store.dampers(path)
    assert path.read_text() == "not a database\n"


def test_a_new_database_is_built_by_every_step(tmp_path: Path) -> None:
    # A fresh file takes the same steps an old one does: the same tables, whichever way.
    fresh = tmp_path / "fresh.sqlite"
    store.dampers(fresh)
    old = tmp_path / "old.sqlite"
    _version_1(old)
    store.dampers(old)

    def layout(p: Path) -> list[tuple[str, str]]:
        db = sqlite3.connect(p)
        rows = db.execute("SELECT type, name FROM sqlite_master ORDER BY type, name").fetchall()
        db.close()
        return rows

    assert layout(fresh) == layout(old)


def test_a_recording_that_grew_by_a_resume_is_shown_once(tmp_path: Path) -> None:
    # A sweep stopped after one test, fitted, resumed and fitted again: one file and
    # date, two SHA-256s. Both are kept; `history` shows the grown one.
    path = tmp_path / "history.sqlite"
    fit = store.ResultEntry("fit", {}, "2026-03-01T10:00:00Z")
    for sha, n in (("partial", 1), ("whole", 20)):
        rec = store.RecordingEntry(sha, "r.mcap", "S46", "jd", "2026-03-01T09:00:00Z", n_tests=n)
        store.add(path, rec, fit)
    other = store.RecordingEntry("later", "r.mcap", "S46", "jd", "2026-04-01T09:00:00Z", n_tests=3)
    store.add(path, other, fit)  # the same path swept again another day: its own recording
    everything = store.visits(path, "S46")
    shown, left_out = store.grown(everything)
    assert [v.recording.sha256 for v in everything] == ["partial", "whole", "later"]
    assert [v.recording.sha256 for v in shown] == ["whole", "later"] and left_out == 1


def test_a_value_at_a_bound_of_zero_shows_as_zero_within_its_sigma() -> None:
    from shockdyno.history.view import Series

    s = Series("sensor_lag.delay_s", "ms", 1e3, (4.018e-17, 0.0021), (6.0e-6, 1e-4))
    assert s.shown(0) == "0 ±0.006"  # it read 4.018e-17 ±1.5e+16%
    assert s.shown(1) == "2.1 ±4.8%"
