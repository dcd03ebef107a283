"""FIT.json of a damper with several adjusters names them; one of the one rod adjuster is
written key for key as before (no `adjusters`, no trend `adjuster`)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from shockdyno.errors import FitError
from shockdyno.fit.result import ClickFit, FitResult
from shockdyno.fit.trend import AreaTrend
from shockdyno.model.spec import default_spec_path

ONE_KEYS = {
    "clicks", "gas_clicks", "A_bc_m2", "A_bt_m2", "A_b_talbott_m2", "A_bc_sd_m2", "A_bt_sd_m2",
    "A_b_talbott_sd_m2", "identifiable_bc", "identifiable_bt", "objective_n",
    "objective_talbott_n", "bleed_share_bc", "bleed_share_bt",
}  # fmt: skip


def test_a_one_adjuster_fit_is_written_as_before() -> None:
    fit = FitResult.from_spec(default_spec_path(), (0, 10))
    fit.trend = {"A_bc": AreaTrend(1, (1e-7, 0.0), (0, 10), 0.0, 1.0, "AICc")}
    doc = fit.to_json()
    assert all(set(c) == ONE_KEYS for c in doc["clicks"])
    assert "adjuster" not in doc["trend"]["A_bc"]
    assert fit.adjuster_names() == []


def test_adjusters_round_trip_and_a_line_is_a_one_adjuster_fit(tmp_path: Path) -> None:
    def cf(c: int, r: int) -> ClickFit:
        return ClickFit(c, 0, 1e-6 * (c + 1), 1e-7 * (r + 1), 5e-7,
                        adjusters={"compression": c, "rebound": r})  # fmt: skip

    fit = FitResult(
        spec_path=str(default_spec_path()),
        globals={},
        clicks=[cf(10, 10), cf(0, 10), cf(20, 10), cf(10, 0), cf(10, 20)],
        trend={"A_bc": AreaTrend(1, (1e-6, 1e-6), (0, 10, 20), 0.0, 1.0, "AICc", 0, "compression")},
    )
    path = tmp_path / "FIT.json"
    fit.save(path)
    assert json.loads(path.read_text())["clicks"][0]["adjusters"] == {
        "compression": 10,
        "rebound": 10,
    }
    back = FitResult.load(path)
    assert [c.adjusters for c in back.clicks] == [c.adjusters for c in fit.clicks]
    assert back.trend["A_bc"].adjuster == "compression"
    line = back.for_adjuster("rebound")
    assert sorted(c.clicks for c in line.clicks) == [0, 10, 20]
    # A_bt moved with the rebound adjuster (no trend given here: its values); A_bc held
    assert line.trend["A_bc"].degree == 0
    assert line.trend["A_bc"].at(5) == pytest.approx(1e-6 * 11)
    assert line.areas(20) == (pytest.approx(1.1e-5), pytest.approx(2.1e-6))
    with pytest.raises(FitError, match="no adjuster 'hs'"):
        back.for_adjuster("hs")
    # the ride study sweeps one adjuster's clicks: it asks which
    from shockdyno.cli import main

    assert main(["ride", "--fit", str(path), "--json", str(tmp_path / "r.json")]) == 2
    assert not (tmp_path / "r.json").exists()


def test_a_recording_of_adjusters_is_refused_with_a_spec_without_them() -> None:
    from dataclasses import replace

    from shockdyno.fit import fit_sweep
    from shockdyno.fit.synthetic import synthetic_sweep
    from shockdyno.model.spec import load_spec

    tests = synthetic_sweep(load_spec(None), [4], cycles=1, seed=1)
    named = [
        replace(t, meta=replace(t.meta, adjusters={"compression": 4, "rebound": 9})) for t in tests
    ]
    with pytest.raises(
        FitError, match=r"name adjusters compression, rebound; the spec .* has one rod"
    ):
        fit_sweep(named)
    two = Path(__file__).resolve().parents[2] / "sim" / "two-adjuster.toml"
    with pytest.raises(FitError, match=r"name adjusters none .* has compression, rebound"):
        fit_sweep(tests, two)
