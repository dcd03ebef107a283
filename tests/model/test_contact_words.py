"""A stop's text gives each side's own curve and the loss's speed only where the fit moved
them off their nominal values."""

from __future__ import annotations

from shockdyno.model.params import Estimate
from shockdyno.model.reading import Reading
from shockdyno.model.terms.contact import Contact


def _text(**given: tuple[float, float]) -> str:
    values = {
        "bump_onset_m": Estimate(0.019, 2e-5, "m"),
        "bump_force_n": Estimate(660.0, 4.0, "N"),
        "topout_onset_m": Estimate(-0.0279, 1e-4, "m"),
        "topout_force_n": Estimate(256.0, 17.0, "N"),
        "hysteresis": Estimate(0.15, 0.006, "1"),
    }
    values |= {k: Estimate(v, sd, "") for k, (v, sd) in given.items()}
    return Contact().describe(Reading(Contact.PARAMS, values, reach_m=(-0.03, 0.03)))


def test_each_side_gives_its_own_curve_where_it_moved() -> None:
    text = _text(exponent=(1.93, 0.008), topout_exponent=(1.01, 0.054))
    bump, _, top = text.partition(" and a top-out spring")
    assert "as depth^1.9 ± 0.008" in bump and "depth^1" not in bump.replace("^1.9", "")
    assert "as depth^1 ± 0.054" in top
    held = _text()  # both at 2, not fitted: no curve named
    assert "depth^" not in held


def test_the_loss_speed_is_given_where_it_moved() -> None:
    text = _text(hysteresis_velocity_m_s=(0.0501, 0.0016))
    assert "15 ± 0.6 % harder going in than coming out" in text
    assert "taken up by 50 ± 1.6 mm/s into the stop" in text
    assert "taken up by" not in _text()
