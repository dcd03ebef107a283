"""Calibration with limits for a term's factor on a spec value (Term.calibrates: the gas
spring's volume): once the baseline has calibrated it, a refit of the search that walks it
beyond a spec's error is held within it (tolerance.hold, refit's limits reaching the term's
bounds), and a value the recording still asks for is reported as a finding, never as
calibrated. Before, the search's refits were free to walk the gas volume to the end of its
range (5x) and the verdict listed it as "calibrated"."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from shockdyno.diagnose.baseline import calibration_rows
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.diagnose.tolerance import hold
from shockdyno.diagnose.verdict import calibration_text
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec
from shockdyno.model.terms import make_term

FACTOR = "gas_spring.volume_factor"


@pytest.fixture(scope="module")
def walked() -> tuple[Data, Fitted]:
    """A damper whose gas column is 4x the drawing's (beyond a spec's 0.5-2x), fitted with
    the gas volume free: the fit walks it to about 4x."""
    drawing = load_spec(None)
    real = drawing.with_values({"gas_length_m": 4 * drawing.gas_length_m})
    prepared, _ = prepare_tests(synthetic_sweep(real, [5, 15], cycles=3, seed=5))
    data = Data.build(drawing, prepared)
    model = DamperModel(drawing, (make_term("gas_spring"),))
    fitted = refit(data, model, (FACTOR,), None, max_nfev=30)
    assert fitted.model.value(FACTOR) == pytest.approx(4.0, rel=0.1)
    return data, fitted


def test_a_refit_holds_a_term_factor_within_its_limit(walked: tuple[Data, Fitted]) -> None:
    data, fitted = walked
    held = refit(data, fitted.model, (FACTOR,), fitted, max_nfev=30, limits={FACTOR: (0.5, 2.0)})
    assert held.model.value(FACTOR) <= 2.0 + 1e-9
    assert held.model.value(FACTOR) == pytest.approx(2.0, rel=1e-3)
    # A refit started from the held fit keeps the limit (Fitted.limits), as a global's.
    again = refit(data, held.model, (FACTOR,), held, max_nfev=10)
    assert again.model.value(FACTOR) <= 2.0 + 1e-9


def test_a_factor_walked_beyond_a_spec_error_is_held_then_a_finding(
    walked: tuple[Data, Fitted],
) -> None:
    from shockdyno.diagnose.tolerance import calibrating

    data, fitted = walked
    spec = data.prob.base
    asked: dict = {}  # type: ignore[type-arg]
    # Only a factor the baseline calibrated is held: a term the search claims is physics.
    assert hold(data, spec, fitted, asked, 10) is fitted and not asked
    held = hold(data, spec, fitted, asked, 10, calibrating(fitted))
    assert set(asked) == {FACTOR} and asked[FACTOR].value == pytest.approx(4.0, rel=0.1)
    assert held.limits[FACTOR] == (0.5, 2.0)
    assert held.model.value(FACTOR) == pytest.approx(2.0, rel=1e-3)

    # The final refit freed it and the recording still asks 4x: a finding, not calibrated.
    gas = make_term("gas_spring")
    (row,) = calibration_rows(spec, fitted, [gas], 0.05, asked)[-1:]
    assert row.parameter == "gas_volume_m3" and row.beyond, row
    assert row.asked / row.spec_value == pytest.approx(4.0, rel=0.1)
    d = SimpleNamespace(calibration=[row], trials=[])
    text = calibration_text(d)  # type: ignore[arg-type]
    assert text.startswith("A finding, not a calibration: the spec's gas volume is"), text
    assert "Calibrated" not in text and "held within it while the search ran" in text

    # Held, and the factor came back within a spec's error: a calibration (the ask is the
    # row's; a candidate's fit may have made it, so the text claims nothing took its place).
    (back,) = calibration_rows(spec, held, [gas], 0.05, asked)[-1:]
    assert not back.beyond and back.asked == row.asked
    text = calibration_text(SimpleNamespace(calibration=[back], trials=[]))  # type: ignore[arg-type]
    assert "A finding" not in text and "Held within" not in text, text
    assert text.startswith("Calibrated, not physics: the spec's gas volume is 2× too small"), text


def test_a_factor_at_its_range_end_is_never_calibrated(walked: tuple[Data, Fitted]) -> None:
    data, fitted = walked
    # The gas volume at the top of its declared range (5x), with a σ a bound gives (3σ
    # reaches the spec's: judged by σ alone it would not even have moved).
    at_end = fitted.model.with_values({FACTOR: 5.0})
    end = Fitted(at_end, fitted.free, fitted.areas, {FACTOR: 2.0}, fitted.force, fitted.residual)
    (row,) = calibration_rows(data.prob.base, end, [make_term("gas_spring")], 0.05)[-1:]
    assert row.beyond, row
    text = calibration_text(SimpleNamespace(calibration=[row], trials=[]))  # type: ignore[arg-type]
    assert "Calibrated" not in text and "A finding, not a calibration" in text, text


def test_a_candidate_that_walks_the_gas_volume_is_tried_again_held(
    walked: tuple[Data, Fitted],
) -> None:
    # The route seen beside aerated oil: the baseline calibrated the gas volume within a
    # spec's error, and a position force's refit walked it to the end of its range and gave
    # the spring back. That candidate is tried again with the volume held, and the volume
    # stays held for the rest of the search.
    import numpy as np

    from shockdyno.diagnose.candidates import Candidate
    from shockdyno.diagnose.search import Search
    from shockdyno.diagnose.settings import Settings
    from shockdyno.diagnose.stats import noise_draws

    data, far = walked
    spec = data.prob.base
    base = refit(data, far.model.with_values({FACTOR: 1.5}), (FACTOR,), None, max_nfev=1)
    s = Settings(n_boot=19, max_nfev=4)
    search = Search(data, base, s, np.random.default_rng(0), [], 1000.0)
    search.drawing = spec
    fake = Candidate("position_force", far, 1.0, 0.001, 1.0, 1.0, np.zeros(0))
    noise = noise_draws(search.binned, np.random.default_rng(1), s.n_boot)
    other = Candidate("thermal", base, 1.0, 0.001, 1.0, 1.0, np.zeros(0))
    got, kept = search._held_tried(1, ["position_force", "thermal"], noise, [fake, other])
    assert got is not fake and got.name == "position_force"
    # One that stayed within is not refitted, and carries the hold on (it may be claimed).
    assert kept.fitted.model is base.model and kept.fitted.limits[FACTOR] == (0.5, 2.0)
    assert got.fitted.model.value(FACTOR) <= 2.0 + 1e-9
    assert search.base.limits[FACTOR] == (0.5, 2.0)
    assert search.asked[FACTOR].value == pytest.approx(4.0, rel=0.1)
