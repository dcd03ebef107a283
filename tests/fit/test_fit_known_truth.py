"""The fit on sweeps made from the model itself, with rig-like noise: known answers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from fit_helpers import TRUE_GLOBALS, nominal, true_spec

from shockdyno.errors import ConfigError, FitError
from shockdyno.fit import FitResult, fit_sweep, table4, table4_rows
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model import damper_force, load_spec
from shockdyno.record.types import TestData, TestMeta

CLICKS = [0, 2, 6, 14]


@pytest.fixture(scope="module")
def sweep() -> list[TestData]:
    return synthetic_sweep(true_spec(), CLICKS, cycles=2, seed=11)


@pytest.fixture(scope="module")
def fit(sweep: list[TestData]) -> FitResult:
    stages: list[tuple[str, float]] = []
    result = fit_sweep(sweep, progress=lambda s, f: stages.append((s, f)))
    fractions = [f for _, f in stages]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    return result


def test_globals_start_away_from_truth() -> None:
    for key, value in TRUE_GLOBALS.items():
        assert abs(value / nominal(key) - 1) >= 0.09, key


def test_proposed_reaches_e_t_below_005_on_every_test(fit: FitResult) -> None:
    assert len(fit.tests) == len(CLICKS) * 3
    for t in fit.tests:
        assert t.proposed["E_t"] <= 0.05, t


def test_globals_are_recovered(fit: FitResult) -> None:
    assert fit.info.calibration is not None
    sd = fit.info.calibration.globals_sd
    for key, value in TRUE_GLOBALS.items():
        got = fit.globals[key]
        assert got == pytest.approx(value, rel=0.02), key
        assert abs(got - value) <= 4 * sd[key] + 1e-3 * value, key


def test_areas_match_truth_within_uncertainty_and_10_percent(fit: FitResult) -> None:
    truth = true_spec()
    checked = 0
    for c in fit.clicks:
        t_bc, t_bt = (float(a) for a in truth.bleed_areas(c.clicks))
        for got, sd, true, ok in (
            (c.a_bc_m2, c.a_bc_sd_m2, t_bc, c.identifiable_bc),
            (c.a_bt_m2, c.a_bt_sd_m2, t_bt, c.identifiable_bt),
        ):
            if not ok:
                continue
            checked += 1
            assert abs(got - true) <= 3 * sd, (c.clicks, got, true, sd)
            assert got == pytest.approx(true, rel=0.10)
    assert checked == 2 * (len(CLICKS) - 1)  # every open click, both directions


def test_closed_bleed_is_flagged_not_identifiable(fit: FitResult) -> None:
    zero = next(c for c in fit.clicks if c.clicks == 0)
    assert not zero.identifiable_bc and not zero.identifiable_bt
    assert zero.bleed_share_bc < 0.02 and zero.bleed_share_bt < 0.02


def test_proposed_beats_talbott_at_every_frequency(fit: FitResult) -> None:
    rows = table4(fit)
    assert [r.frequency_hz for r in rows] == [0.5, 1.0, 1.5]
    for r in rows:
        for key in ("E_t", "E_x", "E_xd"):
            assert r.proposed[key] < r.talbott[key], (r.frequency_hz, key)
            assert r.enhancement_pct[key] > 50


def test_table4_text_rows_match_the_numbers(fit: FitResult) -> None:
    header, rows = table4_rows(fit)
    assert header == ["Frequency (Hz)", "Model", "E_t", "E_x", "E_ẋ"]
    assert [r[1] for r in rows] == ["Proposed", "Talbott", "Enhancement (%)"] * 3
    assert rows[0][0] == "0.5 (4 tests)"
    mean_e_t = np.mean([t.proposed["E_t"] for t in fit.tests if t.frequency_hz == 0.5])
    assert float(rows[0][2]) == pytest.approx(mean_e_t, rel=1e-3)


def test_trend_follows_the_areas(fit: FitResult) -> None:
    truth = true_spec()
    for name, idx in (("A_bc", 0), ("A_bt", 1)):
        trend = fit.trend[name]
        assert trend.clicks_used == (2, 6, 14)
        for n in trend.clicks_used:
            # 3 points: a straight line, so only the shape's broad trend is expected
            assert np.polyval(trend.coefficients, n) == pytest.approx(
                float(truth.bleed_areas(n)[idx]), rel=0.35
            )


def test_json_round_trip_rebuilds_the_fitted_damper(fit: FitResult, tmp_path: Path) -> None:
    path = tmp_path / "fit.json"
    fit.save(path)
    back = FitResult.load(path)
    assert back.globals == fit.globals
    assert [c.a_bc_m2 for c in back.clicks] == [c.a_bc_m2 for c in fit.clicks]
    spec = back.spec()
    assert spec.friction_n == pytest.approx(TRUE_GLOBALS["friction_n"], rel=0.02)
    assert spec.rebound_valve.preload_m == fit.globals["rebound_valve.preload_m"]
    assert back.areas(6) == (fit.clicks[2].a_bc_m2, fit.clicks[2].a_bt_m2)
    assert back.info.table4 is not None and back.info.table4[0].frequency_hz == 0.5


def test_equal_areas_make_the_models_tie() -> None:
    area = 3.0e-6
    tests = synthetic_sweep(
        true_spec(), [5, 12], cycles=2, seed=5, areas={5: (area, area), 12: (area, area)}
    )
    fit = fit_sweep(tests)
    for c in fit.clicks:
        assert c.a_b_talbott_m2 == pytest.approx(area, rel=0.01)
        assert c.a_bc_m2 == pytest.approx(area, rel=0.01)
        assert c.a_bt_m2 == pytest.approx(area, rel=0.01)
    for r in table4(fit):
        for key in ("E_t", "E_x", "E_xd"):
            assert abs(r.enhancement_pct[key]) < 5, (r.frequency_hz, key, r.enhancement_pct)


def _imported(spec_areas: dict[int, tuple[float, float]], with_temperature: bool) -> list[TestData]:
    """300 Hz, non-sinusoidal motion with jittered time stamps, like another dyno's export."""
    spec = true_spec()
    rng = np.random.default_rng(2)
    out = []
    for i, (c, (a_bc, a_bt)) in enumerate(spec_areas.items()):
        t_true = np.arange(0, 6.0, 1 / 300)
        comps = [(0.012, 0.4, 0.3), (0.008, 1.1, 1.7), (0.004, 2.3, 0.2)]  # (amp m, Hz, phase)
        x = sum(a * np.sin(2 * np.pi * f * t_true + p) for a, f, p in comps)
        v = sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * t_true + p) for a, f, p in comps)
        acc = sum(
            -a * (2 * np.pi * f) ** 2 * np.sin(2 * np.pi * f * t_true + p) for a, f, p in comps
        )
        force = damper_force(spec, x, v, acc, a_bc, a_bt) + rng.normal(0, 3.0, t_true.size)
        t = t_true + rng.uniform(-3e-4, 3e-4, t_true.size)  # logger jitter: not uniform
        temp = 38 + 0.2 * t_true if with_temperature else None
        meta = TestMeta(i, c, 0, 0.0, 0.0, 300.0, motion="imported")
        out.append(TestData(meta, t, x + rng.normal(0, 4e-6, t.size), force, temp))
    return out


@pytest.mark.parametrize("with_temperature", [True, False])
def test_imported_300hz_non_sinusoidal(with_temperature: bool) -> None:
    truth = true_spec()
    areas = {c: (float(truth.bleed_areas(c)[0]), float(truth.bleed_areas(c)[1])) for c in (4, 10)}
    fit = fit_sweep(_imported(areas, with_temperature))
    for t in fit.tests:
        assert t.proposed["E_t"] <= 0.05
        assert (t.temperature_mean_c is not None) == with_temperature
    for c in fit.clicks:
        assert c.a_bc_m2 == pytest.approx(areas[c.clicks][0], rel=0.10)
        assert c.a_bt_m2 == pytest.approx(areas[c.clicks][1], rel=0.10)


def test_unusable_input_is_a_typed_error(sweep: list[TestData]) -> None:
    with pytest.raises(FitError):
        fit_sweep([])
    short = TestData(sweep[0].meta, sweep[0].t[:5], sweep[0].x[:5], sweep[0].force[:5])
    with pytest.raises(FitError):
        fit_sweep([short])
    with pytest.raises(ConfigError):
        fit_sweep(sweep[:1], optimizer="simplex")
    with pytest.raises(ConfigError):
        fit_sweep(sweep[:1], spec_path="/nonexistent/spec.toml")


def test_nan_samples_are_dropped() -> None:
    tests = synthetic_sweep(true_spec(), [8], frequencies_hz=(1.0,), cycles=2, seed=4)
    d = tests[0]
    force = d.force.copy()
    force[100:110] = math.nan
    fit = fit_sweep([TestData(d.meta, d.t, d.x, force)])
    assert fit.tests[0].n_samples == d.t.size  # resampled back onto the full grid
    assert fit.tests[0].proposed["E_t"] <= 0.05
    assert load_spec().friction_n != fit.globals["friction_n"]


def test_channel_delay_is_calibrated() -> None:
    """A force channel 1 ms behind the displacement (e.g. a load-cell filter)."""
    truth = true_spec()
    tests = synthetic_sweep(truth, [0, 4, 12], cycles=2, seed=8, force_delay_s=1e-3)
    fit = fit_sweep(tests)
    cal = fit.info.calibration
    assert cal is not None and cal.force_delay_s is not None and cal.force_delay_sd_s is not None
    assert cal.force_delay_s == pytest.approx(1e-3, rel=0.05)
    assert abs(cal.force_delay_s - 1e-3) <= 4 * cal.force_delay_sd_s + 2e-5
    for t in fit.tests:
        assert t.proposed["E_t"] <= 0.05
    for c in fit.clicks[1:]:
        assert c.a_bc_m2 == pytest.approx(float(truth.bleed_areas(c.clicks)[0]), rel=0.02)
        assert c.a_bt_m2 == pytest.approx(float(truth.bleed_areas(c.clicks)[1]), rel=0.02)


def test_a_direction_the_data_barely_sample_is_not_identifiable() -> None:
    """Half a cycle, x from +A to -A: rebound only, bar a few ripple samples."""
    truth = true_spec()
    d = synthetic_sweep(truth, [7], frequencies_hz=(1.0,), cycles=2, seed=1)[0]
    keep = (d.t > 0.25) & (d.t < 0.75)
    fit = fit_sweep([TestData(d.meta, d.t[keep], d.x[keep], d.force[keep])])
    c = fit.clicks[0]
    assert not c.identifiable_bc
    assert c.identifiable_bt
    assert c.a_bt_m2 == pytest.approx(float(truth.bleed_areas(7)[1]), rel=0.02)


def test_two_gas_settings_are_separate_click_settings() -> None:
    truth = true_spec()
    tests = synthetic_sweep(truth, [3, 9], cycles=1, seed=2)
    tests += synthetic_sweep(truth, [9], cycles=1, seed=3, gas_clicks=6)
    fit = fit_sweep(tests)
    assert [(c.clicks, c.gas_clicks) for c in fit.clicks] == [(3, 0), (9, 0), (9, 6)]
    for c in fit.clicks:
        true_bt = float(truth.bleed_areas(c.clicks, c.gas_clicks)[1])
        assert c.a_bt_m2 == pytest.approx(true_bt, rel=0.02)
    assert fit.trend["A_bt"].gas_clicks == 0 and fit.trend["A_bt"].clicks_used == (3, 9)
