"""The sensor-lag term's words name only what a sweep can read: a delay of the force and a
lag of the LVDT shift the loop alike to first order (x(t - δ) ≈ x - δ ẋ against x + τ_x ẋ), so
when the fit moved both it says their difference and that they cannot be told apart, not
two sensors."""

from __future__ import annotations

from shockdyno.model.params import Estimate
from shockdyno.model.reading import Reading
from shockdyno.model.terms.sensor_lag import SensorLag


def _words(delay_ms: float, cell_ms: float, lvdt_ms: float) -> str:
    values = {
        "delay_s": Estimate(delay_ms * 1e-3, 0.02e-3, "s"),
        "load_cell_lag_s": Estimate(cell_ms * 1e-3, 0.02e-3, "s"),
        "lvdt_lag_s": Estimate(lvdt_ms * 1e-3, 0.02e-3, "s"),
    }
    return SensorLag().describe(Reading(SensorLag.PARAMS, values))


def test_a_delay_beside_an_lvdt_lag_is_read_as_their_difference() -> None:
    text = _words(1.42, 3.39, 1.37)  # a 3.4 ms load cell read by a fresh-seed sweep
    assert "force lags the motion by 3.44 ms" in text, text
    assert "load-cell lag 3.4" in text, text
    assert "pure delay less LVDT lag 0.05 ms" in text, text
    assert "cannot tell a force delay from an LVDT lag" in text, text
    assert "pure delay 1.4" not in text and "LVDT lag 1.4" not in text, text


def test_a_delay_alone_is_named_as_a_delay() -> None:
    text = _words(4.0, 0.0, 0.0)
    assert "force lags the motion by 4 ms in all (pure delay 4 ± 0.02 ms)" in text, text
    assert "cannot tell" not in text, text
