"""schema.convert: a config's mistakes in one line naming the key; a result file's keys
beyond the reader's skipped."""

from __future__ import annotations

import datetime as dt
import os
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from shockdyno.errors import ConfigError
from shockdyno.result_files import read_result
from shockdyno.schema import convert, read_toml, shown


@dataclass(frozen=True)
class Valve:
    preload_m: float
    enabled: bool = True


@dataclass(frozen=True)
class Damper:
    name: str
    valve: Valve
    clicks: list[int] = field(default_factory=list)


GOOD = {"name": "s46", "valve": {"preload_m": 1e-4, "enabled": False}, "clicks": [0, 7]}


def _error(data: object, unknown_keys: bool = False) -> str:
    with pytest.raises(ConfigError) as err:
        convert(data, Damper, "damper.toml", unknown_keys=unknown_keys)
    assert "\n" not in str(err.value)
    return str(err.value)


def test_an_int_where_a_bool_goes_names_the_key() -> None:
    bad = GOOD | {"valve": {"preload_m": 1e-4, "enabled": 1}}
    said = _error(bad)
    assert said == "damper.toml: valve.enabled: must be true or false (no quotes), got 1"


def test_an_unknown_key_is_named_with_the_nearest_known_one() -> None:
    bad = GOOD | {"valve": {"preload_m": 1e-4, "enabeld": True}}
    assert _error(bad) == "damper.toml: valve.enabeld: unknown key (did you mean enabled?)"


def test_a_missing_key_says_missing() -> None:
    assert _error({"name": "s46", "valve": {}}) == "damper.toml: valve.preload_m: missing"


def test_unknown_keys_are_skipped_when_allowed_and_refused_by_default() -> None:
    newer = GOOD | {"schema": 2, "valve": {"preload_m": 1e-4, "shims": [{"od_m": 0.02}]}}
    got = convert(newer, Damper, "RESULT.json", unknown_keys=True)
    assert got == Damper("s46", Valve(1e-4), [0, 7])
    assert "unknown key" in _error(newer)
    # Still checked where known: a wrong type is an error either way.
    assert _error(GOOD | {"clicks": [0.5]}, unknown_keys=True) == (
        "damper.toml: clicks[0]: must be a whole number, got 0.5"
    )


def test_non_finite_numbers_are_refused_in_configs_and_results() -> None:
    # A result is written with null for a non-finite number (allow_nan=False): a NaN in
    # one was not written by this project.
    nan = GOOD | {"valve": {"preload_m": float("nan")}}
    assert _error(nan) == "damper.toml: valve.preload_m: must be a finite number, got nan"
    with pytest.raises(ConfigError, match=r"^RESULT.json: valve.preload_m: must be a finite"):
        convert(nan, Damper, "RESULT.json", unknown_keys=True)


def test_a_file_that_is_not_text_says_what_it_is(tmp_path: Path) -> None:
    rec = tmp_path / "rig.toml"
    rec.write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)))  # a recording given as the rig
    with pytest.raises(ConfigError, match=r"rig.toml: is an MCAP recording, not a text file$"):
        read_toml(rec, "missing")
    rec.write_bytes("name = 'Müller'".encode("latin-1"))
    with pytest.raises(ConfigError, match=r"rig.toml: is not UTF-8 text$"):
        read_toml(rec, "missing")
    with pytest.raises(ConfigError, match=r"^rig file not found: x$"):
        read_toml(tmp_path / "none.toml", "rig file not found: x")


@dataclass(frozen=True)
class Entry:
    value: float


@dataclass(frozen=True)
class Nested:
    terms: dict[str, dict[str, Entry]]


def test_a_bad_value_inside_a_table_of_tables_names_its_key() -> None:
    doc = {"terms": {"a": {"x": {"value": 1.0}}, "b": {"x": {"value": 1.0}, "y": {"value": "?"}}}}
    with pytest.raises(ConfigError, match=r"^f: terms.b.y.value: must be a number, got '\?'$"):
        convert(doc, Nested, "f")


def test_a_bom_is_read_and_a_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    bom = tmp_path / "bom.toml"
    bom.write_bytes("\ufeffa = 1\n".encode())  # as some Windows editors save
    assert read_toml(bom, "missing")[1] == {"a": 1}
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match=r"fifo.toml: not a regular file$"):
        read_toml(fifo, "missing")


def test_bad_values_are_shown_as_the_file_spells_them() -> None:
    assert shown(None) == "null" and shown(True) == "true" and shown({"a": 1}) == "a table"
    assert shown(dt.date(1979, 5, 27)) == "1979-05-27" and shown([1, "a"]) == '[1, "a"]'
    assert shown("x" * 100).endswith("...") and len(shown("x" * 100)) == 40


def test_a_result_given_as_a_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "FIT.json"
    os.mkfifo(fifo)  # `ride --fit` on one used to wait for a writer forever
    with pytest.raises(ConfigError, match=r"^--fit: .*FIT.json is not a regular file; expected"):
        read_result(fifo, "--fit", "fit")
