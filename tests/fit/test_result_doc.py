"""FIT.json is read through its typed document: what was written reads back the same,
older and newer files read, and a garbled value is one line naming the key."""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path

import pytest

from shockdyno.errors import ConfigError
from shockdyno.fit.result import FitResult
from shockdyno.model.params import Estimate
from shockdyno.model.spec import default_spec_path


def _saved(tmp_path: Path) -> tuple[Path, FitResult]:
    r = FitResult.from_spec(default_spec_path(), [0, 10, 21])
    r.globals["friction_n"] = 31.5
    r.terms = {
        "sensor_lag": {"delay_s": Estimate(0.004, 1e-4, "s")},
        "cavitation": {"release_pressure_pa": Estimate(-math.inf, math.nan, "Pa", fixed=True)},
    }
    path = tmp_path / "FIT.json"
    r.save(path)
    return path, r


def test_a_saved_fit_reads_back_the_same(tmp_path: Path) -> None:
    path, r = _saved(tmp_path)
    back = FitResult.load(path)
    assert back.to_json() == r.to_json()
    floor = back.terms["cavitation"]["release_pressure_pa"]
    assert math.isnan(floor.value) and floor.fixed  # JSON's null: the term's infinite off
    assert back.spec().friction_n == 31.5


def test_older_and_newer_files_read(tmp_path: Path) -> None:
    old = {  # the keys the first fits wrote, nothing else
        "spec_path": str(default_spec_path()),
        "globals": {},
        "clicks": [{"clicks": 5, "A_bc_m2": 1e-6, "A_bt_m2": 2e-6, "A_b_talbott_m2": 1.5e-6}],
    }
    p = tmp_path / "old.json"
    p.write_text(json.dumps(old))
    r = FitResult.load(p)
    assert r.clicks[0].gas_clicks == 0 and math.isnan(r.clicks[0].a_bc_sd_m2)
    assert r.areas(5) == (1e-6, 2e-6)
    newer = dict(old, provenance={"by": "a later version"})
    newer["clicks"] = [dict(old["clicks"][0], new_key=1)]
    p.write_text(json.dumps(newer))
    assert FitResult.load(p).areas(5) == (1e-6, 2e-6)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["clicks"][1].update(A_bc_m2="big"), r"clicks\[1\].A_bc_m2: must be a number"),
        (lambda d: d["clicks"][0].pop("A_bt_m2"), r"clicks\[0\].A_bt_m2: missing"),
        (lambda d: d["globals"].update(friction_n=[1]), r"globals.friction_n: must be a number"),
        (
            lambda d: d["terms"]["sensor_lag"]["delay_s"].update(fixed="yes"),
            r"terms.sensor_lag.delay_s.fixed: must be true or false",
        ),
        (
            lambda d: d["clicks"][2].update(clicks=2.5),
            r"clicks\[2\].clicks: must be a whole number",
        ),
        (
            lambda d: d["clicks"][2].update(clicks=-3),
            r"clicks\[2\].clicks: must be a whole number >=",
        ),
        (
            lambda d: d["globals"].update(friction_n=math.nan),
            r"globals.friction_n: must be a finite",
        ),
    ],
)
def test_a_garbled_value_is_one_line_naming_the_key(tmp_path: Path, change, message) -> None:
    path, _ = _saved(tmp_path)
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(ConfigError, match=message) as info:
        FitResult.load(path, "--fit")
    assert str(info.value).startswith(f"--fit: {path}: ") and "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        (lambda d: d["globals"].update(friction_n=-500.0), "friction_n: must be a number >= 0"),
        (lambda d: d["globals"].update(frictoin_n=5.0), "unknown damper parameter 'frictoin_n'"),
        (lambda d: d.update(spec_path="/nowhere/x.toml"), "damper spec not found: /nowhere"),
        (lambda d: d["terms"].update(bogus={}), "unknown physics term 'bogus'"),
    ],
)
def test_a_fit_that_reads_but_describes_no_damper_is_not_usable(
    tmp_path: Path, change, problem: str
) -> None:
    path, _ = _saved(tmp_path)
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(ConfigError, match="not a usable fit: .*" + re.escape(problem)):
        FitResult.load(path).require_usable(f"--fit {path}")


def _with_spec(tmp_path: Path, spec_path: str) -> Path:
    """The saved fit with its spec_path replaced (a fit JSON is user input)."""
    path, _ = _saved(tmp_path)
    doc = json.loads(path.read_text())
    doc["spec_path"] = spec_path
    path.write_text(json.dumps(doc))
    return path


def test_a_spec_path_is_followed_only_to_a_damper_spec(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from shockdyno.cli import main

    repo = Path(__file__).resolve().parents[2]
    os.mkfifo(tmp_path / "pipe.toml")  # read, it would block for ever
    (tmp_path / "zero.toml").symlink_to("/dev/zero")  # read, it would never end
    (tmp_path / "folder.toml").mkdir()
    (tmp_path / "big.toml").write_text("# x\n" * 300_000)  # 1.2 MB, no spec
    cases = {
        "/etc/passwd": "is not a damper spec (a .toml file); not read",
        "": "is not a damper spec (a .toml file)",
        str(repo / "rigs/sim.toml"): "is not a damper spec: ",  # another kind of TOML
        str(tmp_path / "pipe.toml"): "is not a regular file; not read",
        str(tmp_path / "zero.toml"): "is not a regular file; not read",
        str(tmp_path / "folder.toml"): "is not a regular file; not read",
        str(tmp_path / "big.toml"): "bytes, no damper spec",
        "nowhere/s.toml": "damper spec not found: nowhere/s.toml or ",
    }
    for spec_path, said in cases.items():
        fit = _with_spec(tmp_path, spec_path)
        with pytest.raises(ConfigError, match=re.escape(said)) as err:
            FitResult.load(fit).spec()
        assert "\n" not in str(err.value)
        # a command that takes the fit: one line, exit 2, nothing written
        out = tmp_path / f"table{len(spec_path)}"
        assert main(["export", str(fit), "--damper-table", str(out)]) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and said in lines[0] and "Traceback" not in lines[0]
        assert not out.exists()


def test_a_relative_spec_path_is_found_from_here_or_beside_the_fit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    text = default_spec_path().read_text()
    (tmp_path / "specs").mkdir()
    (tmp_path / "specs/mine.toml").write_text(text)
    fit = _with_spec(tmp_path, "specs/mine.toml")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    loaded = FitResult.load(fit)
    assert loaded.spec_file() == tmp_path / "specs/mine.toml"  # beside the fit
    assert loaded.spec().friction_n == 31.5  # the fit's global on the spec found
    # from the working folder first: the path as `fit --spec` was given it
    (elsewhere / "specs").mkdir()
    (elsewhere / "specs/mine.toml").write_text(text)
    assert FitResult.load(fit).spec_file() == Path("specs/mine.toml")


def test_every_key_fit_writes_is_declared_by_its_typed_document(tmp_path: Path) -> None:
    """FIT.json has one definition (fit/result_doc.py) that `fit` builds and every reader
    reads: read strictly, an undeclared key anywhere in the file is an error, and the typed
    document written again is the file, byte for byte."""
    from shockdyno.cli import main
    from shockdyno.fit.result_doc import FitDoc
    from shockdyno.schema import convert, to_json

    out = tmp_path / "example.json"
    example = Path(__file__).parents[2] / "recordings" / "examples" / "example.mcap"
    assert main(["fit", str(example), "--json", str(out), "--no-history"]) == 0
    text = out.read_text()
    doc = convert(json.loads(text), FitDoc, str(out))  # unknown keys refused
    assert doc.info.calibration is not None and doc.info.table4 and doc.info.velocity_range
    assert doc.info.recording is not None and doc.terms["sensor_lag"] and doc.trend
    assert json.dumps(to_json(doc), indent=2, allow_nan=False) + "\n" == text
    assert json.dumps(FitResult.load(out).to_json(), indent=2, allow_nan=False) + "\n" == text
    raw = json.loads(text)
    raw["info"]["calibration"]["prior"] = 1  # a key written untyped
    with pytest.raises(ConfigError, match=r"info\.calibration\.prior"):
        convert(raw, FitDoc, str(out))
