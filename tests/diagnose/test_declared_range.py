"""A chain of refits keeps each spec value within its declared range about the spec the
diagnosis started from (fit/parameters.SPEC_GLOBALS), not about each refit's own start:
taken about the start, the seal's smoothing speed walked to 1e-7 of the drawing's."""

from __future__ import annotations

import pytest

from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.fit.parameters import spec_global
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec


def test_a_refit_from_a_drifted_start_stays_in_the_declared_range() -> None:
    drawing = load_spec(None)
    lo, _ = spec_global("gas_pressure_pa").bounds(drawing.gas_pressure_pa)  # 0.2x
    # The damper's charge is a tenth of the drawing's: beyond the declared range.
    real = drawing.with_values({"gas_pressure_pa": 0.1 * drawing.gas_pressure_pa})
    prepared, _ = prepare_tests(synthetic_sweep(real, [5, 15], cycles=3, seed=5))
    data = Data.build(drawing, prepared)
    first = refit(data, DamperModel(drawing), (), None, max_nfev=30)
    assert first.model.spec.gas_pressure_pa == pytest.approx(lo, rel=1e-3)
    # A refit from that fit: about its own value the range would reach 0.04x, and the
    # data ask for 0.1x.
    again: Fitted = refit(data, first.model, (), first, max_nfev=30)
    assert again.model.spec.gas_pressure_pa >= lo * (1 - 1e-9)
    assert again.model.spec.gas_pressure_pa == pytest.approx(lo, rel=1e-3)
