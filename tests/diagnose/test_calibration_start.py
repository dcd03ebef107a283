"""A calibration whose error has more than one basin starts from the best of its declared
starts (`SpecGlobal.starts`), not only the spec's value: the seal's turn."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.diagnose.candidates import binned_means, calibration_start, try_candidate
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import CALIBRATIONS, Fitted, refit
from shockdyno.diagnose.stats import noise_draws
from shockdyno.fit.parameters import spec_global
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import DamperSpec, load_spec

TURN = CALIBRATIONS["seal_turn"]


def _base(real: DamperSpec, spec: DamperSpec) -> tuple[Data, Fitted]:
    tests = synthetic_sweep(real, [5, 15], cycles=3, seed=11)
    prepared, _ = prepare_tests(tests)
    data = Data.build(spec, prepared)
    return data, refit(data, DamperModel(spec), (), None, max_nfev=30)


def test_the_seal_turn_starts_from_the_travel_it_has_and_is_fitted_to_it() -> None:
    spec = load_spec(None)
    # A seal that deflects 10 µm and then slides with a sharp sign; the spec says a sign
    # smoothed over 1 mm/s with no travel.
    real = spec.with_values({"friction_presliding_m": 1e-5, "friction_velocity_m_s": 1e-4})
    data, base = _base(real, spec)
    start = calibration_start(data, base, "seal_turn")
    # Of the declared starts, the nearest to the truth.
    assert start.spec.friction_presliding_m == pytest.approx(1e-5)
    assert start.spec.friction_velocity_m_s == pytest.approx(1e-4)
    means, binned = binned_means(data, base.residual)
    noise = noise_draws(binned, np.random.default_rng(0), 99)
    c = try_candidate(data, base, means, "seal_turn", noise, 20)
    assert set(TURN) <= set(c.fitted.globals)
    assert c.fitted.model.spec.friction_presliding_m == pytest.approx(1e-5, rel=0.2)


def test_a_spec_that_is_right_keeps_its_own_start() -> None:
    spec = load_spec(None)
    data, base = _base(spec, spec)
    start = calibration_start(data, base, "seal_turn")
    assert start.spec.friction_presliding_m == 0.0
    assert start.spec.friction_velocity_m_s == spec.friction_velocity_m_s


def test_the_starts_lie_in_the_range_each_is_calibrated_within() -> None:
    spec = load_spec(None)
    for key in TURN:
        g = spec_global(key)
        lo, hi = g.bounds(spec.value(key))
        assert g.starts and all(lo <= v <= hi for v in g.starts), key
