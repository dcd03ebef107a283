"""A claim is judged again at the values the verdict reports.

A candidate is claimable only with physical values (Term.implausible), but the verdict
reports the final refit on every test, which can move them: on a reference-plant sweep
with a 60 N seal and no vapour, a cavitation floor claimed above vacuum less the gas
charge refitted to -2.55 MPa absolute and was reported as found. The final refit now
drops such a claim, says why, and refits the model without it."""

from __future__ import annotations

import numpy as np

from shockdyno.diagnose.candidates import with_term
from shockdyno.diagnose.claims import at_range_end
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.diagnosis import Trial
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.diagnose.search import Search
from shockdyno.diagnose.settings import Settings
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec


def _claimed(name: str) -> Trial:
    return Trial(name, 1, True, 0.001, 100.0, 0.5, "", 5.0, 20.0, {})


def _final(floor_pa: float) -> tuple[list[str], list[Trial], Fitted]:
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
    search = Search(data, base, Settings(), np.random.default_rng(0), [], force_peak)
    search.claimed, search.trials = claimed, findings
    final = search.final_refit(data)
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


def test_a_term_pinned_at_an_end_of_its_range_is_not_an_estimate() -> None:
    """A free parameter at an end of its range that is not its off value: the data want
    more than the term allows (no heat in the plant: damping +5 %/K, lead 1000 s)."""
    spec = load_spec(None)
    prepared, _ = prepare_tests(synthetic_sweep(spec, [5], cycles=2, seed=6))
    data = Data.build(spec, prepared)
    plain = refit(data, DamperModel(spec), (), None, max_nfev=10)
    model = with_term(plain.model, "thermal", data)
    term = model.term("thermal")
    assert term is not None
    free = tuple(term.qualified(k) for k in ("damping_coeff_per_k", "oil_lead_s"))

    def fitted(values: dict[str, float]) -> Fitted:
        m = model.with_values({term.qualified(k): v for k, v in values.items()})
        return Fitted(m, free, plain.areas, {}, plain.force, plain.residual)

    assert "upper end of its range (0.05 1/K)" in at_range_end(
        fitted({"damping_coeff_per_k": 0.0499999, "oil_lead_s": 150.0}), term
    )
    assert "oil_lead_s sits at the upper end" in at_range_end(
        fitted({"damping_coeff_per_k": 0.01, "oil_lead_s": 1000.0}), term
    )
    assert at_range_end(fitted({"damping_coeff_per_k": 0.01, "oil_lead_s": 150.0}), term) == ""
    # At the end that is its off value (no lead) the term is only partly on: an estimate.
    assert at_range_end(fitted({"damping_coeff_per_k": 0.01, "oil_lead_s": 0.0}), term) == ""
    # A parameter the fit held is not judged where it was put.
    held = Fitted(
        model.with_values({term.qualified("viscosity_coeff_per_k"): 0.1}),
        free, plain.areas, {}, plain.force, plain.residual,
    )  # fmt: skip
    assert at_range_end(held, term) == ""
