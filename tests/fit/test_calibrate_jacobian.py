"""A calibration without the robust loss reports σ from the solver's own final Jacobian.

trf evaluates the residual and the Jacobian at every point it accepts, so the ones it
returns are those at its end; the calibration used to compute that Jacobian once more
for the covariance (one model evaluation in nine of a diagnosis). With the check switched
on, `calibrate` asserts that what it takes is bit for bit what it would have computed."""

from __future__ import annotations

import numpy as np
import pytest

import shockdyno.fit.calibrate as calibrate_module
from shockdyno.fit.areas import start_areas
from shockdyno.fit.calibrate import calibrate
from shockdyno.fit.parameters import global_parameters
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.problem import StackedProblem
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model import load_spec
from shockdyno.model.composite import DamperModel
from shockdyno.model.terms import make_term


@pytest.mark.parametrize("terms", [(), ("compressibility",)])
def test_the_final_jacobian_is_the_one_the_solver_ended_with(
    terms: tuple[str, ...], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(calibrate_module, "CHECK_SOLVER_JACOBIAN", True)
    spec = load_spec()
    prepared, _ = prepare_tests(synthetic_sweep(spec, [4, 14], cycles=2, seed=5), 100.0)
    model = DamperModel(spec, tuple(make_term(t) for t in terms))
    free = tuple(f"{t}.air_fraction" for t in terms)
    prob = StackedProblem(spec, prepared).for_model(model, free)
    bc, bt = start_areas(prob, model, spec.bleed_bore_area_m2)
    cal = calibrate(
        prob, model, global_parameters(spec), free, bc, bt, spec.bleed_bore_area_m2,
        max_nfev=6, robust=False,
    )  # fmt: skip
    assert np.all(np.isfinite(cal.sd_bc)) and cal.nfev <= 6
