"""A claim the final refit would drop is judged again in the form it was claimed in.

The later rounds' refits may move a parameter the claim left at its off value: a
reference-plant heat claimed with the viscosity's coefficient at 0 and damping falling
0.17 %/K had that coefficient walked to 0.1 1/K, its range's end, and the final refit then
dropped the claim as "not an estimate". The final refit now refits such a claim with those
parameters back at off and held, keeps that when the claim then holds up, and the
verdict's `fit --terms` holds them too."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from shockdyno.diagnose.candidates import with_term
from shockdyno.diagnose.claims import left_off
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.diagnosis import Trial
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.diagnose.search import Search, idle_reasons
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.verdict import fit_terms
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.fit.terms import parse_terms
from shockdyno.model.composite import DamperModel
from shockdyno.model.params import Estimate
from shockdyno.model.spec import load_spec

B, D = "thermal.viscosity_coeff_per_k", "thermal.damping_coeff_per_k"
G, LEAD = "thermal.gas_coupling", "thermal.oil_lead_s"


def _heat(values: dict[str, float]) -> tuple[Data, Fitted]:
    spec = load_spec(None)
    prepared, _ = prepare_tests(synthetic_sweep(spec, [5], cycles=2, seed=6))
    data = Data.build(spec, prepared)
    plain = refit(data, DamperModel(spec), (), None, max_nfev=10)
    model = with_term(plain.model, "thermal", data).with_values(values)
    return data, Fitted(model, (G, B, D, LEAD), plain.areas, {}, plain.force, plain.residual)


def test_the_parameters_a_claim_left_at_off_are_named() -> None:
    _, fitted = _heat({G: 0.8, B: 0.0, D: 0.002, LEAD: 60.0})
    assert left_off(fitted, ["thermal"]) == (B,)
    # Moved, however little beyond a thousandth of its scale (0.01 1/K): not left at off.
    _, fitted = _heat({G: 0.8, B: 2e-5, D: 0.002, LEAD: 60.0})
    assert left_off(fitted, ["thermal"]) == ()
    # Held by the fit, or a term the model does not have: nothing to hold.
    _, fitted = _heat({G: 0.8, B: 0.0, D: 0.002, LEAD: 60.0})
    assert left_off(Fitted(fitted.model, (G, D), fitted.areas, {}, fitted.force,
                           fitted.residual), ["thermal"]) == ()  # fmt: skip
    assert left_off(fitted, ["friction"]) == ()


def _heated() -> Data:
    """Two tests at 25 °C, two at 55 °C, their force thinned 1 %/K about 40 °C (as oil
    thinner in every path would): a heat effect that damping_coeff_per_k alone describes."""
    spec = load_spec(None)
    tests = []
    for temp, seed in ((25.0, 6), (55.0, 7)):
        for t in synthetic_sweep(spec, [5], (0.5, 1.5), temperature_c=temp, seed=seed):
            meta = replace(t.meta, index=len(tests))
            tests.append(replace(t, meta=meta, force=t.force * math.exp(-0.01 * (temp - 40.0))))
    return Data.build(spec, prepare_tests(tests)[0])


def _search(data: Data, base: Fitted, claimed_without: tuple[str, ...]) -> Search:
    force_peak = float(np.max(np.abs(data.prob.f)))
    search = Search(data, base, Settings(), np.random.default_rng(0), [], force_peak)
    search.claimed = ["thermal"]
    search.claimed_without = {"thermal": claimed_without}
    search.trials = [Trial("thermal", 1, True, 0.001, 100.0, 0.5, "", 5.0, 20.0, {})]
    return search


def test_a_claim_the_final_refit_would_drop_is_judged_in_its_claimed_form() -> None:
    data = _heated()
    plain = refit(data, DamperModel(data.prob.base), (), None, max_nfev=10)
    model = with_term(plain.model, "thermal", data).with_values({B: 0.0, D: 0.01})
    claim = refit(data, model, (G, D, LEAD), plain, max_nfev=20)  # how it was claimed
    claim = replace(claim, free=(G, B, D, LEAD))
    assert set(left_off(claim, ["thermal"])) == {G, B}  # no gas force to follow here
    # Where later refits left it: the viscosity's coefficient at its range's end.
    later = replace(claim, model=claim.model.with_values({B: 0.1}))
    why = idle_reasons(["thermal"], data, later, float(np.max(np.abs(data.prob.f))), Settings())
    assert "upper end of its range" in why["thermal"]
    again, why_again = _search(data, later, (G, B)).as_claimed(data, later, why, 20)
    assert why_again == {}
    assert B not in again.free and G not in again.free and again.model.value(B) == 0.0
    # d scales Δp, not the gas force the test's factor also thinned: a little under 1 %/K.
    assert 0.007 < again.model.value(D) < 0.011
    # A claim made with every parameter free has no other form to be judged in.
    same, why_same = _search(data, later, ()).as_claimed(data, later, why, 20)
    assert same is later and why_same == why


def test_a_claim_no_form_of_which_holds_up_is_still_dropped() -> None:
    """No heat in the data: held in its claimed form the term's force is too small, and
    the reasons stand."""
    spec = load_spec(None)
    data = Data.build(spec, prepare_tests(synthetic_sweep(spec, [5], cycles=2, seed=6))[0])
    plain = refit(data, DamperModel(spec), (), None, max_nfev=10)
    model = with_term(plain.model, "thermal", data).with_values({G: 0.0, B: 0.1, D: 0.01})
    later = Fitted(model, (G, B, D, LEAD), plain.areas, {}, plain.force, plain.residual)
    why = {"thermal": "refitted on every test it is not an estimate: ..."}
    again, why_again = _search(data, later, (G, B)).as_claimed(data, later, why, 20)
    assert again is later and why_again == why


def test_the_fit_command_holds_what_the_diagnosis_held() -> None:
    def est(v: float, fixed: bool = False) -> Estimate:
        return Estimate(v, math.nan if fixed else 0.1 * abs(v) + 1e-6, "", fixed=fixed)

    trial = Trial(
        "thermal", 1, True, 0.001, 100.0, 0.5, "", 5.0, 20.0,
        {"gas_coupling": est(0.8), "viscosity_coeff_per_k": est(0.0, fixed=True),
         "damping_coeff_per_k": est(0.002), "oil_lead_s": est(60.0)},
    )  # fmt: skip
    command = fit_terms([trial])
    free = parse_terms(command).free
    assert B not in free, command
    assert {G, D, LEAD} <= set(free), command
    # Nothing held: the term by its name, as before.
    trial.parameters["viscosity_coeff_per_k"] = est(0.03)
    assert fit_terms([trial]).split(",")[0] == "thermal"
