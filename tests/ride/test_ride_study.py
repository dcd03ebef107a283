"""The ride study on the fitted (here: true) nonlinear damper, and its linear checks."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from shockdyno.errors import ConfigError, FitError
from shockdyno.fit.result import FitResult
from shockdyno.fit.trend import AreaTrend
from shockdyno.model.quarter_car import QuarterCar, accel_transfer
from shockdyno.ride.study import RideConfig, run_study

SHORT = {"duration_s": 10.0, "warmup_s": 3.0, "step_check": False}


@pytest.fixture(scope="module")
def nonlinear(true_fit: FitResult):  # type: ignore[no-untyped-def]
    config = RideConfig(clicks=(5, 10, 15), roads=("A", "E"), speeds_kmh=(20.0, 120.0), **SHORT)  # type: ignore[arg-type]
    return run_study(config, true_fit)


def test_fewer_clicks_ride_harsher_on_a_smooth_road(nonlinear) -> None:  # type: ignore[no-untyped-def]
    """Not the paper's finding. On road A the suspension moves slowly (< 0.2 m/s), where
    this damper's rates (6-8 kN·s/m, ζ ≈ 0.6-0.9) are already past the comfort optimum
    (ζ ≈ 0.3, test_ride_quarter_car): more damping (fewer clicks) lowers the body
    resonance peak but passes more 2-8 Hz road input, and the RMS rises."""
    for v in (20.0, 120.0):
        rms = [nonlinear.rms_of(c, "A", v) for c in (5, 10, 15)]
        assert rms[0] > rms[1] > rms[2], (v, rms)
    i5 = nonlinear.runs.index(next(r for r in nonlinear.runs if r.clicks == 5))
    i15 = nonlinear.runs.index(next(r for r in nonlinear.runs if r.clicks == 15))
    f = nonlinear.psd_hz
    peak = (f > 1.0) & (f < 2.5)
    # The 15-click car's body resonance is the higher (less damped) one, as theory says.
    assert np.max(nonlinear.psd_m2_s4_hz[i15, peak]) > np.max(nonlinear.psd_m2_s4_hz[i5, peak])


def test_fewer_clicks_ride_smoother_on_the_roughest_road_at_speed(nonlinear) -> None:  # type: ignore[no-untyped-def]
    """The paper's direction appears where the damper works at high speed (road E at
    120 km/h: ~4 m/s stroke speeds): there fewer clicks lower the RMS, by ~2 %."""
    rms = [nonlinear.rms_of(c, "E", 120.0) for c in (5, 10, 15)]
    assert rms[0] < rms[1] < rms[2]
    assert rms[2] / rms[0] - 1 < 0.05


def test_linear_study_matches_theory_and_scales_with_the_road(true_fit: FitResult) -> None:
    c = 2000.0
    config = RideConfig(roads=("A", "C"), speeds_kmh=(80.0,), linear_damper_ns_m=c, **SHORT)  # type: ignore[arg-type]
    res = run_study(config)
    rms_a, rms_c = res.rms_of(None, "A", 80.0), res.rms_of(None, "C", 80.0)
    assert rms_c / rms_a == pytest.approx(4.0, rel=1e-9)  # PSD × 16
    road = res.roads[("A", 80.0)]
    omega_t = road.omega_rad_m * 80 / 3.6
    theory = math.sqrt(
        np.sum((accel_transfer(QuarterCar(), c, omega_t) * road.amplitude_m) ** 2) / 2
    )
    assert rms_a == pytest.approx(theory, rel=1e-3)
    again = run_study(config)
    assert again.rms_of(None, "A", 80.0) == rms_a  # the same seed, the same road, bit for bit
    other = run_study(RideConfig(**{**config.__dict__, "seed": 1}))
    assert other.rms_of(None, "A", 80.0) != rms_a


def test_step_check_reports_a_small_change(true_fit: FitResult) -> None:
    config = RideConfig(
        clicks=(5,), roads=("A", "D"), speeds_kmh=(20.0, 120.0), duration_s=2.0,
        warmup_s=1.0, check_duration_s=2.0,
    )  # fmt: skip
    res = run_study(config, true_fit)
    check = res.step_check
    assert check is not None and len(check.runs) == 2
    assert check.max_relative_change < 1e-3


def test_bad_study_requests_are_config_errors(true_fit: FitResult) -> None:
    with pytest.raises(ConfigError, match="fit result"):
        run_study(RideConfig(**SHORT))  # type: ignore[arg-type]
    with pytest.raises(FitError, match="no result for 7 clicks"):
        run_study(RideConfig(clicks=(7,), **SHORT), true_fit)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="stability"):
        run_study(RideConfig(dt_s=5e-3, **SHORT), true_fit)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="speed"):
        run_study(RideConfig(speeds_kmh=(-20.0,), **SHORT), true_fit)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="whole number"):
        run_study(RideConfig(duration_s=10.0005, warmup_s=1.0, dt_s=1e-3), true_fit)


def test_clicks_the_fit_did_not_measure_come_from_its_trend(true_fit: FitResult) -> None:
    from shockdyno.model import load_spec

    spec = load_spec()
    n = np.arange(0, 22)
    a_bc, a_bt = spec.bleed_areas(n)
    trend = {
        "A_bc": AreaTrend.from_json({"coefficients": np.polyfit(n, a_bc, 4).tolist()}),
        "A_bt": AreaTrend.from_json({"coefficients": np.polyfit(n, a_bt, 4).tolist()}),
    }
    fit = FitResult(true_fit.spec_path, {}, true_fit.clicks, trend=trend)
    config = RideConfig(
        clicks=(7, 10), roads=("B",), speeds_kmh=(60.0,), duration_s=2.0, warmup_s=1.0,
        step_check=False,
    )  # fmt: skip
    res = run_study(config, fit)
    seven, ten = res.damper_info.settings
    assert seven.source == "trend" and ten.source == "fit"
    true_bc7 = float(spec.bleed_areas(7)[0])
    assert seven.A_bc_m2 == pytest.approx(true_bc7, rel=0.05)
    talbott = run_study(replace(config, clicks=(10,), model="talbott"), fit)
    setting = talbott.damper_info.settings[0]
    assert setting.A_bc_m2 == setting.A_bt_m2 == true_fit.clicks[1].a_b_talbott_m2
