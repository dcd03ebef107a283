"""FitResult.areas: fitted values, the trend between them, never an extrapolation."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.errors import FitError
from shockdyno.fit.result import ClickFit, FitResult
from shockdyno.fit.trend import AreaTrend
from shockdyno.model.spec import default_spec_path


def _result() -> FitResult:
    clicks = [ClickFit(c, 0, 1e-6 * (c + 1), 5e-7 * (c + 1), 8e-7 * (c + 1)) for c in (5, 15)]
    trend = {
        "A_bc": AreaTrend.from_json({"coefficients": [1e-6, 1e-6]}),  # A = 1e-6 (n + 1)
        "A_bt": AreaTrend.from_json({"coefficients": [5e-7, 5e-7]}),
    }
    return FitResult(str(default_spec_path()), {}, clicks, trend=trend)


def test_fitted_clicks_give_their_own_areas():
    r = _result()
    assert r.areas(15) == (16e-6, 8e-6)
    assert r.areas(5, model="talbott") == (4.8e-6, 4.8e-6)


def test_clicks_between_fitted_ones_follow_the_trend():
    bc, bt = _result().areas(10)
    assert bc == pytest.approx(np.polyval([1e-6, 1e-6], 10))
    assert bt == pytest.approx(np.polyval([5e-7, 5e-7], 10))


@pytest.mark.parametrize("clicks", [0, 4, 16, 30, -1])
def test_clicks_outside_the_fitted_range_are_refused(clicks):
    with pytest.raises(FitError, match="outside the fitted range 5-15"):
        _result().areas(clicks)


def test_a_gas_setting_gets_its_own_areas_never_another_s():
    """A sweep over the gas bottle's clicks fits each (rod, gas) pair: areas(5) took the
    first pair with 5 rod clicks whatever its gas, so the click chart drew the gas-3 test
    with the gas-0 areas."""
    r = _result()
    r.clicks.append(ClickFit(5, 3, 9e-6, 7e-6, 8e-6))
    assert r.main_gas_clicks() == 0
    assert r.areas(5) == (6e-6, 3e-6) == r.areas(5, gas_clicks=0)
    assert r.areas(5, gas_clicks=3) == (9e-6, 7e-6)
    with pytest.raises(FitError, match="outside the fitted range 5-5 at 3 gas clicks"):
        r.areas(10, gas_clicks=3)  # the trend is gas 0's: not lent to gas 3
    with pytest.raises(FitError, match="no result at 7 gas clicks"):
        r.areas(5, gas_clicks=7)
    bc, _ = r.areas(10)  # gas 0: the trend, as before
    assert bc == pytest.approx(np.polyval([1e-6, 1e-6], 10))
