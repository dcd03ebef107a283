"""A term that acts on one test only is judged on that test's second half, trained on its
first: vapour on the stiffest click at 1.5 Hz only. No whole-test split can place it (the
tests that train never reach the floor), and on reference-plant sweeps its held-out gain
came only from the tests it does nothing on (0.04-0.05), so it was never claimable."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from shockdyno.diagnose.candidates import (
    Candidate,
    _acts_on,
    baseline_folds,
    binned_means,
    folds,
    heldout_gain,
    try_candidate,
)
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import refit
from shockdyno.diagnose.stats import noise_draws
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel, ModelInputs
from shockdyno.model.spec import DamperSpec, load_spec
from shockdyno.model.terms import make_term

RELEASE_PA = 3000.0


def _sweep(spec: DamperSpec, truth: DamperModel) -> Data:
    """Clicks 2/10/20 x 0.5/1/1.5 Hz, four cycles each, the force `truth`'s plus noise."""
    rng = np.random.default_rng(1)
    tests = []
    for td in synthetic_sweep(spec, [2, 10, 20], cycles=4, seed=5):
        bc, bt = spec.bleed_areas(td.meta.clicks, 0)
        w, t = 2 * np.pi * td.meta.frequency_hz, td.t
        x, v, a = 0.03 * np.sin(w * t), 0.03 * w * np.cos(w * t), -0.03 * w * w * np.sin(w * t)
        f = truth.force(ModelInputs.single(x, v, a), float(bc), float(bt))
        noisy = replace(td, x=x + rng.normal(0, 3e-6, t.size), force=f + rng.normal(0, 3.0, t.size))
        tests.append(noisy)
    prepared, _ = prepare_tests(tests)
    return Data.build(spec, prepared)


@pytest.fixture(scope="module")
def vapour_on_one_test() -> tuple[Data, Candidate]:
    spec = load_spec(None)
    spec = spec.with_values({"gas_pressure_pa": 0.4 * spec.gas_pressure_pa})
    truth = DamperModel(spec, (make_term("cavitation"),))
    truth = truth.with_values({"cavitation.release_pressure_pa": RELEASE_PA})
    data = _sweep(spec, truth)
    base = refit(data, DamperModel(spec), (), None, max_nfev=30)
    means, binned = binned_means(data, base.residual)
    noise = noise_draws(binned, np.random.default_rng(0), 199)
    cand = try_candidate(data, base, means, "cavitation", noise, 15)
    return data, cand


def test_the_plant_makes_vapour_on_one_test_only(
    vapour_on_one_test: tuple[Data, Candidate],
) -> None:
    data, cand = vapour_on_one_test
    assert cand.p_value < 0.01
    floor = cand.fitted.model.value("cavitation.release_pressure_pa")
    assert abs(floor - RELEASE_PA) < 5e3, floor
    # The whole splits that leave the stiffest click or 1.5 Hz out train on tests that
    # never reach the floor; every other split trains on the test that does.
    blind = {f.label for f in folds(data) if not _acts_on(f.train, cand)}
    assert blind == {"1.5 Hz left out", "2 clicks left out"}


def test_it_is_judged_on_the_second_half_of_the_test_it_acts_on(
    vapour_on_one_test: tuple[Data, Candidate],
) -> None:
    data, cand = vapour_on_one_test
    fold_list = folds(data)
    assert all(f.halves is not None for f in fold_list)
    base = refit(data, DamperModel(data.prob.base), (), None, max_nfev=30)
    gain, detail = heldout_gain(baseline_folds(fold_list, base, 8), cand, 8)
    assert "1.5 Hz left out, its second halves predicted from its first" in detail
    assert "skipped" not in detail
    assert gain > 0.5, detail
    # The two folds that leave its test out say nothing without the halves (skipped:
    # a gain of 0 from no structure judged), and nearly all with them.
    blind = [f for f in fold_list if f.label in ("1.5 Hz left out", "2 clicks left out")]
    halves_gain, _ = heldout_gain(baseline_folds(blind, base, 8), cand, 8)
    assert halves_gain > 0.9
    whole = [replace(f, halves=None) for f in blind]
    none_gain, none_detail = heldout_gain(baseline_folds(whole, base, 8), cand, 8)
    assert none_gain == 0.0 and none_detail.count("skipped") == 2, none_detail
