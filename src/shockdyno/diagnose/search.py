"""The forward search's steps: one round of candidates (`run_round`), the next round's
candidates (`gated`), the backward check, and the final refit on every test."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.candidates import (
    Candidate,
    Fold,
    binned_means,
    heldout_gains,
    own_peak,
    try_candidate,
)
from shockdyno.diagnose.claims import (
    at_range_end,
    decide,
    effect_limit,
    moved_off,
    score_heldout,
    why_not,
)
from shockdyno.diagnose.consistency import SENSOR, alike, delay_spread, inconsistent
from shockdyno.diagnose.cycles import BinnedTest
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.diagnosis import Trial
from shockdyno.diagnose.fitting import CALIBRATIONS, Fitted, refit
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.stats import MismatchStat, noise_draws
from shockdyno.diagnose.workers import SERIAL, Workers
from shockdyno.model.composite import FORCE, PRESSURE, DamperModel
from shockdyno.model.params import Estimate
from shockdyno.model.terms import LIBRARY
from shockdyno.report.documents import Indistinguishable

FloatArray = NDArray[np.float64]
Progress = Callable[[str, float], None]


def term_estimates(fitted: Fitted, name: str) -> dict[str, Estimate]:
    term = fitted.model.term(name)
    if term is None:
        return {}
    out: dict[str, Estimate] = {}
    for p in term.params():
        q = term.qualified(p.name)
        sd = fitted.term_sd.get(q, math.nan)
        out[p.name] = Estimate(fitted.model.value(q), sd, p.unit, fixed=q not in fitted.free)
    return out


def backward(
    search: Data,
    base: Fitted,
    claimed: list[str],
    trials: list[Trial],
    groups: list[Indistinguishable],
    fold_list: list[Fold],
    rng: np.random.Generator,
    s: Settings,
    came_with: dict[str, tuple[str, ...]] | None = None,
    workers: Workers = SERIAL,
) -> Fitted:
    """Forward selection claims in order, and an early claim can be a later one's misfit
    (a bump stop first pulls the gas spring off the spec's, then a contact term explains
    it all). So each claimed term is tested again as the last to join the others: it
    stays only if it still passes (p < alpha, held-out gain ≥ min_gain_joining); else it
    is dropped from the model and its trial says why. Edits `claimed`, `trials` and
    `groups`; returns the model without the dropped terms. `came_with`: per claimed
    term, the spec values freed with it, which leave with it."""
    came_with = {} if came_with is None else came_with
    for name in list(claimed):
        if len(claimed) < 2:
            break
        if base.model.term(name) is None:
            continue
        model, free, calibrated = without(search, base, [name], came_with)
        reduced = refit(search, model, free, base, max_nfev=s.max_nfev, calibrated=calibrated)
        means, binned = binned_means(search, reduced.residual)
        c = try_candidate(
            search, reduced, means, name, noise_draws(binned, rng, s.n_boot), s.max_nfev
        )
        gain = 0.0
        if fold_list:
            gain = heldout_gains(fold_list, reduced, [c], s.fold_nfev, workers)[0][0]
        if c.p_value < s.alpha and gain >= s.min_gain_joining:
            continue
        others = [n for n in claimed if n != name]
        f = next(f for f in trials if f.physics == name and f.claimed)
        f.claimed = False
        f.why_not = (
            f"dropped in the backward check: with {', '.join(others)} in the model it removes "
            f"{gain:.2g} of the held-out structure left (p = {c.p_value:.2g})"
        )
        claimed.remove(name)
        came_with.pop(name, None)
        groups[:] = [g for g in groups if name not in g.group]
        base = reduced
    return base


def without(
    data: Data, base: Fitted, names: Sequence[str], came_with: Mapping[str, tuple[str, ...]]
) -> tuple[DamperModel, tuple[str, ...], tuple[str, ...]]:
    """The model, its free term parameters and the spec values it calibrates with the
    terms `names` taken out, and the spec values each freed beside it (COMPANIONS) back
    at the spec's: a term retested or dropped is judged without what came with it."""
    model = base.model
    own: set[str] = set()
    keys: set[str] = set()
    for n in names:
        term = model.term(n)
        if term is not None:
            own |= {term.qualified(p.name) for p in term.params()}
            model = model.without(n)
        keys |= set(came_with.get(n, ()))
    if keys:
        model = model.with_spec(model.spec.with_values({k: data.prob.base.value(k) for k in keys}))
    free = tuple(q for q in base.free if q not in own)
    return model, free, tuple(k for k in base.globals if k not in keys)


def search_subset(data: Data, n_clicks: int) -> Data:
    """The tests of at most n_clicks click settings, evenly spread (all when fewer)."""
    keys = sorted({p.key for p in data.prepared})  # a setting: every adjuster's clicks
    if len(keys) <= n_clicks:
        return data
    pick = {keys[round(i)] for i in np.linspace(0, len(keys) - 1, n_clicks)}
    keep = [i for i, p in enumerate(data.prepared) if p.key in pick]
    return data.subset(keep)


def run_round(
    search: Data,
    base: Fitted,
    base_means: FloatArray,
    binned: list[BinnedTest],
    remaining: Sequence[str],
    rnd: int,
    s: Settings,
    rng: np.random.Generator,
    fold_list: list[Fold],
    force_peak: float,
    shapes: Sequence[tuple[str, FloatArray]],
    report: Progress,
    workers: Workers = SERIAL,
) -> tuple[list[Trial], Candidate | None, list[str]]:
    """One round of the forward search: every remaining candidate refitted beside `base`
    and tested (LR against the noise's draws), the significant ones scored held out, the
    claim rules (why_not) applied. Returns the round's trials and the candidate it
    claims (None: nothing claimable), and every candidate that passed the claim rules
    (the claimed one among them). The candidates, and then the held-out folds, are
    independent: up to `workers` processes run them (workers.py)."""
    found: list[Trial] = []
    rounds = s.max_rounds  # for the progress fraction
    noise = noise_draws(binned, rng, s.n_boot)
    n_done = 0

    # The chamber's terms first: they take the longest, and started last they would keep
    # one worker busy after the others finished (the results keep the library's order).
    order = sorted(range(len(remaining)), key=lambda i: not chamber_term(remaining[i]))

    def tried(i: int) -> None:
        nonlocal n_done
        n_done += 1
        share = n_done / len(remaining)
        name = remaining[order[i]]
        report(f"round {rnd}: {name} tried", 0.1 + 0.8 * (rnd - 1 + share) / rounds)

    report(f"round {rnd}: {len(remaining)} candidates", 0.1 + 0.8 * (rnd - 1) / rounds)
    shared = (search, base, base_means, noise, s.max_nfev)
    got = workers.map(_try, shared, [remaining[i] for i in order], tried)
    cands = [got[order.index(i)] for i in range(len(remaining))]
    screened = sorted(
        (c for c in cands if c.p_value < s.screen_alpha and c.lr > 0), key=lambda c: -c.lr
    )
    top = [c for c in screened if c.p_value < s.alpha][: s.heldout_top]
    limit = effect_limit(binned, force_peak, s)
    x = search.prob.inputs.x
    refused = {
        c.name: alike(c.fitted, s.sensor_delay_min_shift_s)
        or inconsistent(
            delay_spread(search, c.fitted, s.sensor_delay_min_gain, s.sensor_delay_min_shift_s),
            s.sensor_delay_spread_s,
            s.sensor_delay_spread_share,
        )
        for c in top
        if c.name == SENSOR
    }
    scored = score_heldout(
        top, cands, base, rnd, s, limit, shapes, x, refused, fold_list, report, workers
    )
    # Each candidate's reason not to be claimed ("" when it is claimable), judged once.
    reasons = {c.name: why_not(c, scored, s, limit, shapes, x, refused) for c in cands}
    best, pool, alike_with = decide(cands, screened, scored, reasons, s)
    for c in cands:
        gain, detail = scored.get(c.name, (math.nan, ""))
        amb = alike_with.get(c.name, [])
        found.append(
            Trial(
                physics=c.name,
                round=rnd,
                claimed=c is best,
                p_value=c.p_value,
                lr_n2=c.lr,
                heldout_gain=gain,
                heldout_detail=detail,
                effect_rms_n=c.effect_rms_n,
                effect_peak_n=c.effect_peak_n,
                parameters=term_estimates(c.fitted, c.name),
                ambiguous_with=amb,
                why_not="" if c is best else (reasons[c.name] or "another term explained more"),
            )
        )
    return found, best, [c.name for c in pool]


def chamber_term(name: str) -> bool:
    """Whether candidate `name` integrates the rebound chamber (the slow refits)."""
    term = LIBRARY.get(name)
    return term is not None and term.stateful and PRESSURE <= term.stage < FORCE


def _try(shared: tuple[Data, Fitted, FloatArray, FloatArray, int], name: str) -> Candidate:
    search, base, base_means, noise, max_nfev = shared
    return try_candidate(search, base, base_means, name, noise, max_nfev)


def gated(
    remaining: Sequence[str],
    left: MismatchStat,
    claimed: Sequence[str],
    outranked: Sequence[str],
    s: Settings,
) -> list[str]:
    """The candidates of the next round. While structure beyond noise is left (`left`,
    p < alpha) and fewer than max_terms are claimed, all that remain. Else physics stops,
    and after a claim the calibrations not yet taken still get rounds of their own (each
    still needs its own p < alpha and held-out gain): a 0.5 % air sweep (reference seed
    723) stopped with the air claimed at 1.62 N RMS of structure (p = 0.04) and the seal's
    turn and the bleed's land at the spec's, 1.36x the clean sweep's E_t, whose baseline
    had taken both. So does a physics term that passed every claim rule in the last round
    but lost it to a calibration (`outranked`): the structure the calibration took was
    not the term's to lose. In reference seed 725's triple, friction beside air and heat
    passed in round 4 (p = 0.001, held-out gain 0.25), a calibration explained more, what
    was left was then within noise, and the friction was never claimed."""
    if left.p_value < s.alpha and len(claimed) < s.max_terms:
        return list(remaining)
    if not claimed:
        return []
    keep = set(CALIBRATIONS) | (set(outranked) if len(claimed) < s.max_terms else set())
    return [c for c in remaining if c in keep]


def final_refit(
    data: Data,
    base: Fitted,
    claimed: list[str],
    trials: list[Trial],
    groups: list[Indistinguishable],
    s: Settings,
    force_peak: float,
    came_with: dict[str, tuple[str, ...]],
) -> Fitted:
    """The model refitted on every test (not only the search's clicks), whose values the
    verdict reports: a candidate's refit is cut at max_nfev, and with the gas spring
    calibrated beside it a bump stop's onset stopped at 24.1 mm where it was 21. A claim
    whose term, refitted to convergence, stays at its off values, or whose own force is
    then below the limit a candidate must pass (0.1 % of the peak force, 3 noise σ of a
    phase mean), was the short refit's gain, not the term's: it leaves the model and the
    verdict (`claimed`, `trials` and `groups` are updated in place). A 2 % air sweep
    kept a position force that refitted to 0.45 N at most, against a 1.8 N limit. And a
    claim whose values, refitted, are no longer physical (term.implausible) leaves too:
    a reference-plant friction sweep's cavitation floor, claimed above vacuum less the
    gas charge, refitted to -2.55 MPa absolute and was reported as the verdict's."""
    nfev = s.final_nfev if claimed else s.max_nfev
    base = refit(data, base.model, base.free, base, max_nfev=nfev)
    limit = effect_limit(data.binned(base.residual), force_peak, s)
    why: dict[str, str] = {}
    for n in claimed:
        term = base.model.term(n)
        if term is None:
            continue
        odd = term.implausible(base.model.local_values(term), base.model.spec)
        if odd:
            why[n] = f"refitted on every test it is not physical: {odd}"
            continue
        pinned = at_range_end(base, term)
        if pinned:
            why[n] = f"refitted on every test it is not an estimate: {pinned}"
            continue
        if not moved_off(base, term):
            why[n] = "refitted on every test it stays at its off values"
            continue
        peak = own_peak(data, base, n)
        if peak < limit:
            why[n] = (
                f"refitted on every test its own force peaks at {peak:.2g} N, too small "
                f"to matter (< {limit:.2g} N)"
            )
    idle = list(why)
    if idle:
        for f in trials:
            if f.claimed and f.physics in idle:
                f.claimed = False
                f.why_not = why[f.physics]
        claimed[:] = [n for n in claimed if n not in idle]
        groups[:] = [g for g in groups if not set(idle) & set(g.group)]
        kept, free, calibrated = without(data, base, idle, came_with)
        for n in idle:
            came_with.pop(n, None)
        nfev = s.final_nfev if claimed else s.max_nfev
        base = refit(data, kept, free, base, max_nfev=nfev, calibrated=calibrated)
    for f in trials:
        if f.claimed:
            f.parameters = term_estimates(base, f.physics)
    return base
