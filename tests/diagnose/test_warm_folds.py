"""A held-out fold's refit starts from the full fit's Jacobian, restricted to its tests.

The fold's training tests are tests of the search, and each test is its own segment of the
model's inputs, so the full fit's Jacobian holds the fold's at the same point: its rows for
those tests and its columns for their clicks. The refit starts from it and updates it by
Broyden's rule (fit/calibrate.py `jac0`) instead of differencing the model at every step."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.diagnose.candidates import folds
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import Fitted, _warm_jacobian, prepared_key, refit
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model import load_spec
from shockdyno.model.composite import DamperModel
from shockdyno.model.terms import make_term


@pytest.fixture(scope="module")
def fitted() -> tuple[Data, Fitted]:
    spec = load_spec()
    sweep = synthetic_sweep(spec, [3, 10, 18], (0.5, 1.5), cycles=4, seed=9)
    prepared, _ = prepare_tests(sweep, 100.0, phase_locked=True)
    data = Data.build(spec, prepared)
    model = DamperModel(spec, (make_term("compressibility"),)).with_values(
        {"compressibility.air_fraction": 0.004}
    )
    fit = refit(data, model, ("compressibility.air_fraction",), None, max_nfev=4)
    return data, fit


def test_the_full_fits_rows_are_the_folds_jacobian(fitted: tuple[Data, Fitted]) -> None:
    data, fit = fitted
    assert fit.jac is not None and len(fit.jac_rows) == data.n_tests
    fold_list = folds(data)
    assert {f.label for f in fold_list} >= {"0.5 Hz left out", "3 clicks left out"}
    for fold in fold_list:
        warm = _warm_jacobian(fold.train, fit)
        assert warm is not None
        # The fold's own Jacobian at the same point: a refit stopped at its start (both per
        # unit of each parameter: a refit scales the globals by where it starts).
        cold = refit(fold.train, fit.model, fit.free, fit, max_nfev=1)
        assert cold.jac is not None and warm.shape == cold.jac.shape
        scale = np.maximum(np.linalg.norm(cold.jac, axis=0), 1e-12)
        assert np.max(np.abs(warm - cold.jac) / scale) < 1e-6, fold.label


def test_a_test_the_full_fit_did_not_see_gets_no_warm_start(
    fitted: tuple[Data, Fitted],
) -> None:
    data, fit = fitted
    halves = [f.halves for f in folds(data) if f.halves is not None]
    assert halves
    assert all(prepared_key(p) not in fit.jac_rows for p in halves[0].train.prepared[-1:])
    assert _warm_jacobian(halves[0].train, fit) is None


def test_a_warm_refit_ends_about_where_a_differenced_one_does(
    fitted: tuple[Data, Fitted],
) -> None:
    """On each fold, the quasi-Newton refit's squared error is within 1 % of the
    differenced refit's, on the same budget."""
    data, fit = fitted
    for fold in folds(data):
        warm = refit(fold.train, fit.model, fit.free, fit, 8, warm=True)
        cold = refit(fold.train, fit.model, fit.free, fit, 8)
        sse_w, sse_c = float(warm.residual @ warm.residual), float(cold.residual @ cold.residual)
        assert sse_w <= 1.01 * sse_c, (fold.label, sse_w, sse_c)
