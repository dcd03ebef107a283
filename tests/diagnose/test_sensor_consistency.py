"""A sensor's delay is one time for the sweep; a lag that changes from test to test is not
a sensor's (aerated oil's grows with the click's resistance)."""

from __future__ import annotations

from shockdyno.diagnose.consistency import delay_spread, inconsistent
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import refit
from shockdyno.diagnose.settings import Settings
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec
from shockdyno.model.terms import make_term


def _spread(delays: dict[int, float]):  # type: ignore[no-untyped-def]
    spec = load_spec(None)
    tests = []
    for i, (click, delay) in enumerate(delays.items()):
        tests += synthetic_sweep(spec, [click], cycles=3, force_delay_s=delay, seed=20 + i)
    prepared, _ = prepare_tests(tests)
    data = Data.build(spec, prepared)
    model = DamperModel(spec, (make_term("sensor_lag"),))
    fitted = refit(data, model, ("sensor_lag.delay_s",), None, max_nfev=30)
    s = Settings()
    spread = delay_spread(data, fitted, s.sensor_delay_min_gain)
    return spread, inconsistent(spread, s.sensor_delay_spread_s, s.sensor_delay_spread_share)


def test_one_delay_on_every_test_is_a_sensors() -> None:
    spread, why = _spread({5: 0.006, 15: 0.006})
    assert spread is not None and len(spread.delays_s) == 6
    assert all(abs(d - 0.006) < 0.0007 for d in spread.delays_s), spread.delays_s
    assert why == ""


def test_a_delay_that_changes_with_the_click_is_not_a_sensors() -> None:
    spread, why = _spread({5: 0.002, 15: 0.012})
    assert spread is not None
    assert spread.hi_s - spread.lo_s > 0.008, spread.delays_s
    assert "from test to test" in why and "ms" in why
