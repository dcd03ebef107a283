"""A claim is judged again at the values the verdict reports.

A candidate is claimable only with physical values (Term.implausible), but the verdict
reports the final refit on every test, which can move them: on a reference-plant sweep
with a 60 N seal and no vapour, a cavitation floor claimed above vacuum less the gas
charge refitted to -2.55 MPa absolute and was reported as found. The final refit now
drops such a claim, says why, and refits the model without it."""

from __future__ import annotations

import numpy as np

from shockdyno.diagnose.candidates import with_term
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.engine import Finding, Settings, _final_refit
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec


def _claimed(name: str) -> Finding:
    return Finding(name, 1, True, 0.001, 100.0, 0.5, "", 5.0, 20.0, {})


def _final(floor_pa: float) -> tuple[list[str], list[Finding], Fitted]:
    spec = load_spec(None)
    prepared, _ = prepare_tests(synthetic_sweep(spec, [5, 15], cycles=3, seed=5))
    data = Data.build(spec, prepared)
    model = with_term(
        refit(data, DamperModel(spec), (), None, max_nfev=20).model, "cavitation", data
    )
    model = model.with_values({"cavitation.release_pressure_pa": floor_pa})
    # Held: the refit cannot move the floor, so the values judged are the ones set here.
    base = refit(data, model, (), None, max_nfev=20)
    claimed, findings = ["cavitation"], [_claimed("cavitation")]
    force_peak = float(np.max(np.abs(data.prob.f)))
    final = _final_refit(data, base, claimed, findings, [], Settings(), force_peak, {})
    return claimed, findings, final


def test_a_claim_whose_final_values_are_not_physical_leaves_the_verdict() -> None:
    claimed, findings, final = _final(-3.0e6)  # below vacuum by more than the 1.6 MPa charge
    assert claimed == []
    assert not findings[0].claimed
    assert "not physical" in findings[0].why_not and "below vacuum" in findings[0].why_not
    assert final.model.term("cavitation") is None


def test_a_physical_floor_is_not_refused_as_unphysical() -> None:
    _, findings, _ = _final(3.0e3)  # the vapour pressure of oil: physics
    assert "not physical" not in findings[0].why_not
