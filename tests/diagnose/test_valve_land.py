"""A shim stack's seat land (spec `valve_land_m`) is calibrated when the recording has one,
though the baseline has bent the valves' preloads and faces to stand in for it."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.diagnose import candidates
from shockdyno.diagnose.candidates import binned_means, try_candidate
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import refit
from shockdyno.diagnose.stats import noise_draws
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec

LAND_M = 0.9e-3


def test_a_seat_land_is_found_from_the_drawings_valves_where_the_baseline_hid_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    spec = load_spec(None)
    real = spec.with_values({"valve_land_m": LAND_M})
    tests = synthetic_sweep(real, [5, 15], cycles=3, seed=11)
    prepared, _ = prepare_tests(tests)
    data = Data.build(spec, prepared)
    base = refit(data, DamperModel(spec), (), None, max_nfev=30)
    # The baseline took the land as stiffer valves: a raised preload.
    assert base.model.spec.rebound_valve.preload_m > 1.03 * spec.rebound_valve.preload_m
    means, binned = binned_means(data, base.residual)
    noise = noise_draws(binned, np.random.default_rng(0), 99)
    c = try_candidate(data, base, means, "valve_land", noise, 30)
    got = c.fitted.model.spec
    assert got.valve_land_m == pytest.approx(LAND_M, rel=0.15)
    assert got.rebound_valve.preload_m == pytest.approx(spec.rebound_valve.preload_m, rel=0.03)
    assert c.p_value <= 0.01  # none of the 99 noise draws explains as much
    # From the baseline alone (no second start) the land only adds error there.
    monkeypatch.setattr(candidates, "RESTARTS", {})
    alone = try_candidate(data, base, means, "valve_land", noise, 30)
    assert alone.fitted.model.spec.valve_land_m < 0.3 * LAND_M
    assert alone.lr < 0.5 * c.lr
