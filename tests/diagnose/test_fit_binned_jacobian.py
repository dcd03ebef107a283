"""A candidate's test of significance reads the Jacobian at its fit from the calibration
that made the fit, not from a second differencing of the model there (as many model
evaluations as columns, a chamber integration each where one runs). The two must be the
same derivatives: column by column within the differencing's error, with a chamber (whose
columns the calibration takes from its linearised steps) and without one; a fit on other
tests than the data's falls back to differencing."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.diagnose.candidates import binned_jacobian, fit_binned_jacobian
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import predict, refit
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec
from shockdyno.model.terms import make_term


@pytest.mark.parametrize(
    ("term", "free"),
    [
        ("friction", ("friction.breakaway_n",)),
        ("compressibility", ("compressibility.air_fraction",)),
    ],
)
def test_the_fits_own_jacobian_is_the_differenced_one(term: str, free: tuple[str, ...]) -> None:
    spec = load_spec(None)
    prepared, _ = prepare_tests(synthetic_sweep(spec, [5, 15], cycles=2, seed=4))
    data = Data.build(spec, prepared)
    model = DamperModel(spec, (make_term(term),)).with_values(
        {free[0]: 0.01 if term != "friction" else 10.0}
    )
    fitted = refit(data, model, free, None, max_nfev=10)
    before = data.prob.evaluations
    own = fit_binned_jacobian(data, fitted)
    assert data.prob.evaluations == before  # read from the fit: no model evaluated
    again, ahead = binned_jacobian(data, fitted)
    assert data.prob.evaluations > before
    assert own.shape == again.shape and ahead == len(fitted.globals) + len(free)
    norms = np.linalg.norm(again, axis=0)
    used = norms > 1e-9 * norms.max()
    assert np.any(used[:ahead]) and np.all(used[ahead:])
    err = np.linalg.norm(own - again, axis=0)[used] / norms[used]
    assert np.max(err) < 0.02, err

    # The fit on other tests (predicted on half of them): no Jacobian of its own here,
    # differenced again.
    half = data.subset(list(range(len(prepared) // 2)))
    there = predict(half, fitted)
    assert np.array_equal(fit_binned_jacobian(half, there), binned_jacobian(half, there)[0])
