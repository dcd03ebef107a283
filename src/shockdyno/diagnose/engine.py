"""The diagnosis: locate the mismatch, name the missing physics, model it, refit.

1. Baseline: the paper's model (or a given fit's model) refitted to the recording; its
   residual is split into structure and noise (cycles.py) and tested (stats.py), and the
   structure located (locate.py).
2. Forward selection: each library term not yet in the model is added and refitted
   jointly with the globals and areas (fitting.py); scored by a bootstrap likelihood
   ratio (p-value) and by held-out prediction (leave one frequency out, one click out,
   or one half of a single test). A term is claimed when both agree (p < alpha and a
   held-out gain of at least `min_gain`, or `min_gain_joining` once a term is claimed)
   and its effect is material; candidates whose
   explained structure has the same shape are reported as indistinguishable. The claimed
   term joins the model and the search repeats on what remains.
3. Open set: `position_force` competes as a candidate, but is claimed only when no named
   term is; what no candidate explains is reported as the unexplained regions.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.candidates import (
    Candidate,
    Fold,
    HeldOut,
    binned_means,
    folds,
    heldout_gains,
    own_peak,
    try_candidate,
)
from shockdyno.diagnose.consistency import SENSOR, alike, delay_spread, inconsistent
from shockdyno.diagnose.cycles import BinnedTest
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.discover import Described, discover
from shockdyno.diagnose.fitting import CALIBRATIONS, Fitted, full_rate_force, refit
from shockdyno.diagnose.locate import Location, locate
from shockdyno.diagnose.settings import Settings as Settings
from shockdyno.diagnose.spikes import remove_spikes
from shockdyno.diagnose.stats import MismatchStat, mismatch_test, noise_draws
from shockdyno.diagnose.workers import SERIAL, Workers
from shockdyno.errors import FitError
from shockdyno.fit.metrics import error_metrics
from shockdyno.fit.parameters import spec_global
from shockdyno.fit.prepare import PreparedTest, prepare_tests, whole_cycles
from shockdyno.fit.result import FitResult
from shockdyno.fit.sweep import check_adjusters
from shockdyno.model.composite import FORCE, PRESSURE, DamperModel, Term
from shockdyno.model.params import Estimate
from shockdyno.model.spec import DamperSpec, default_spec_path, load_spec
from shockdyno.model.terms import LIBRARY, make_term
from shockdyno.record.types import TestData

FloatArray = NDArray[np.float64]
Progress = Callable[[str, float], None]

OPEN_SET = "position_force"


# What separates two candidates that explain the same shape of residual.
def separate_by(a: str, b: str) -> str:
    """What would tell terms a and b apart (Term.separated_by, written on one of the two)."""
    ca, cb = LIBRARY.get(a), LIBRARY.get(b)
    said = (ca.separated_by.get(b) if ca else None) or (cb.separated_by.get(a) if cb else None)
    return said or DEFAULT_SEPARATE


DEFAULT_SEPARATE = "tests at other frequencies, amplitudes and gas pressures"

# The spec's own numbers that a sweep sees and a spec can only guess are calibrated in
# the baseline, never claimed as physics: the globals (gas charge, Coulomb friction,
# valve preloads and face areas, fit/problem.py) and the gas spring rate. A ±30 mm
# stroke pins the rate p0·n·A²/V, not n and V apart, so the gas volume carries it at the
# spec's (isothermal) index. A spec's gas volume is a guess within a factor of two;
# a rate that needs more than that is something else acting over the stroke (a bump
# stop, a top-out spring) and is left to the search.
GAS_VOLUME = "gas_spring.volume_factor"
GAS_VOLUME_RANGE = (0.5, 2.0)


@dataclass
class Trial:
    """One candidate term tried in one round of the search: its refit's scores, the term's
    parameters as fitted, and whether it is claimed (and why not). The search edits it as
    later rounds decide; verdict.py makes each one a row of DIAG.json's `findings`
    (report/documents.py `Finding`)."""

    physics: str
    round: int
    claimed: bool
    p_value: float
    lr_n2: float
    heldout_gain: float
    heldout_detail: str
    effect_rms_n: float
    effect_peak_n: float
    parameters: dict[str, Estimate]  # the term's, at the fit that was scored
    ambiguous_with: list[str] = field(default_factory=list)
    why_not: str = ""


@dataclass(frozen=True)
class CalibrationRow:
    """A spec value the recording calibrated (DIAG.json `verdict.calibration`)."""

    parameter: str
    spec_value: float
    fitted: float
    sd: float
    unit: str
    share: float = Settings.calibration_share
    scale: float = 0.0  # what `share` is of where the spec says 0 (SpecGlobal.fallback)
    tolerance: tuple[float, float] | None = None  # SpecGlobal.tolerance

    @property
    def beyond(self) -> bool:
        """Moved further from the spec's value than a real damper departs from its
        drawing (SpecGlobal.tolerance): a finding, not a calibration."""
        if self.tolerance is None or self.spec_value <= 0 or not self.moved:
            return False
        ratio = self.fitted / self.spec_value
        return not self.tolerance[0] <= ratio <= self.tolerance[1]

    @property
    def moved(self) -> bool:
        """Worth a sentence: off the spec's value by more than `share` of it (of `scale`
        where the spec gives 0: a bleed land of 0.1 mm is a sharp orifice still) and by
        more than three of its σ."""
        off = abs(self.fitted - self.spec_value)
        sd = self.sd if math.isfinite(self.sd) else 0.0
        size = abs(self.spec_value) or self.scale
        return off > self.share * size and off > 3 * sd


@dataclass
class TestScore:
    index: int
    clicks: int
    frequency_hz: float
    e_t_before: float
    e_t_after: float


@dataclass(frozen=True)
class ShortTest:
    """A test of fewer than two whole cycles: it has no cycle-to-cycle scatter, so no noise
    to weigh a mismatch against, and the diagnosis claims nothing from it."""

    index: int
    clicks: int
    frequency_hz: float
    cycles: float


@dataclass
class Diagnosis:
    mismatch: MismatchStat
    location: Location
    trials: list[Trial]
    claimed: list[str]
    indistinguishable: list[dict[str, object]]
    unexplained: Location
    remaining: MismatchStat
    tests: list[TestScore]
    baseline: Fitted
    final: Fitted
    data: Data
    notes: list[str]
    wall_s: float
    single_frequency: bool
    calibration: list[CalibrationRow] = field(default_factory=list)
    settings: Settings = field(default_factory=Settings)  # what the search used; the verdict too
    sensor: list[str] = field(default_factory=list)  # faults of the sensors, not physics
    short_tests: list[ShortTest] = field(default_factory=list)  # left out, see ShortTest
    # What the search left (significant), described, with a discovered term (discover.py)
    described: list[Described] = field(default_factory=list)

    @property
    def alpha(self) -> float:
        return self.settings.alpha

    @property
    def testable(self) -> bool:
        """False when every test was short: no mismatch test, nothing claimed (_untestable)."""
        return not math.isnan(self.mismatch.p_value)


def _parameters(fitted: Fitted, name: str) -> dict[str, Estimate]:
    term = fitted.model.term(name)
    if term is None:
        return {}
    out: dict[str, Estimate] = {}
    for p in term.params():
        q = term.qualified(p.name)
        sd = fitted.term_sd.get(q, math.nan)
        out[p.name] = Estimate(fitted.model.value(q), sd, p.unit, fixed=q not in fitted.free)
    return out


def _cosine(a: FloatArray, b: FloatArray) -> float:
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    return float(a @ b / (na * nb)) if na > 0 and nb > 0 else 0.0


def _e_t(data: Data, fitted: Fitted) -> list[float]:
    out = []
    for p in data.prepared:
        f = full_rate_force(fitted, p)
        out.append(error_metrics(p.data.t, p.data.x, p.data.force, f, v=p.v, a=p.a)["E_t"])
    return out


def _moved_off(fitted: Fitted, term: Term) -> bool:
    """Whether any free parameter of `term` moved off its off value by more than 3σ (and
    a thousandth of its scale). A term that fits better while staying at off explains
    nothing itself: its refit moved the rest (a gas spring at 0.998 ± 0.002 × the spec's
    once took 97 % of what a claimed compressibility's short refit had left)."""
    free = [p for p in term.params() if term.qualified(p.name) in fitted.free]
    if not free:
        return True  # nothing was fitted: nothing to judge
    return any(
        _beyond_noise(
            fitted.model.value(term.qualified(p.name)),
            p.off,
            fitted.term_sd.get(term.qualified(p.name), math.nan),
            p.scale,
        )
        for p in free
    )


def _at_range_end(fitted: Fitted, term: Term) -> str:
    """Why `term` as fitted is not an estimate ("" when it is): a free parameter pinned
    at an end of its range that is not its off value. The data ask for more than the
    term's physics allows there, so the term stands in for something else, and the σ a
    bound gives is no error bar. Seen: a thermal term on reference-plant sweeps with no
    heat effect (a 60 N seal; vapour at a 0.40 gas charge) fitted its damping at ±5 %/K
    and the oil's lead at 1000 s, the range's ends, and was claimed."""
    for p in term.params():
        key = term.qualified(p.name)
        if key not in fitted.free:
            continue
        value = fitted.model.value(key)
        for end, bound in (("lower", p.lo), ("upper", p.hi)):
            # No error bar is known here: within a thousandth of its scale of the bound.
            if bound != p.off and not _beyond_noise(value, bound, math.nan, p.scale):
                return f"its {p.name} sits at the {end} end of its range ({bound:.4g} {p.unit})"
    return ""


def _beyond_noise(value: float, ref: float, sd: float, scale: float) -> bool:
    """Whether a fitted value sits off `ref` by more than 3σ and a thousandth of its scale
    (a value that is not finite has moved)."""
    noise = 3 * sd if math.isfinite(sd) else 0.0
    return not math.isfinite(value) or abs(value - ref) > max(noise, 1e-3 * scale)


def _calibration_idle(c: Candidate, min_effect_n: float) -> str:
    """Why a calibration candidate changed nothing itself ("" when it did): none of its
    spec values moved off the spec's by more than 3σ, or its own force (the model less
    the same with the spec's values) is too small to matter."""
    spec, sds = c.fitted.model.spec, c.fitted.globals_sd
    moved = any(
        _beyond_noise(
            spec.value(key),
            c.spec_values.get(key, 0.0),
            sds.get(key, math.nan),
            spec_global(key).scale(c.spec_values.get(key, 0.0)),
        )
        for key in CALIBRATIONS[c.name]
    )
    if not moved:
        return "its values stay at the spec's: the gain is the refit's"
    if c.own_peak_n < min_effect_n:
        return (
            f"its own force peaks at {c.own_peak_n:.2g} N, too small to matter: the gain is "
            "the refit's"
        )
    return ""


def why_not(
    c: Candidate,
    scored: dict[str, tuple[float, str]] | None,
    s: Settings,
    min_effect_n: float,
    shapes: Sequence[tuple[str, FloatArray]] = (),
    x: FloatArray | None = None,
    refused: Mapping[str, str] | None = None,
) -> str:
    """Why a candidate is not claimable ("" when it is). `shapes`: what each claimed term
    explained; a later term that explains the same shape again refines that physics (a
    lag model's residual looks like more lag), it is not a second one. `refused`: what a
    consistency check (consistency.py) found against a candidate. `scored` None: every
    rule but the held-out gain's (what `_round` asks before it scores a candidate held
    out: a candidate one of them refuses is refused whatever its gain)."""
    if refused and refused.get(c.name):
        return refused[c.name]
    for name, shape in shapes:
        if _cosine(c.explained, shape) > s.same_shape:
            return f"the same shape as {name}, already claimed"
    if c.name in CALIBRATIONS:
        why = _calibration_idle(c, min_effect_n)
        if why:
            return why
    term = c.fitted.model.term(c.name)
    if term is not None:
        odd = term.implausible(c.fitted.model.local_values(term), c.fitted.model.spec)
        if odd:
            return f"not physical: {odd}"
        if x is not None:
            unplaced = term.unplaced(c.fitted.model.local_values(term), x)
            if unplaced:
                return f"not placed: {unplaced}"
        if not _moved_off(c.fitted, term):
            return "its parameters stay at their off values: the gain is the refit's"
        if c.own_peak_n < min_effect_n:
            return (
                f"its own force peaks at {c.own_peak_n:.2g} N, too small to matter: the gain "
                "is the refit's"
            )
        pinned = _at_range_end(c.fitted, term)
        if pinned:
            return f"not an estimate: {pinned}"
    if c.p_value >= s.alpha:
        return f"p = {c.p_value:.3g} ≥ {s.alpha:g}"
    if scored is None:
        return _too_small(c, min_effect_n)
    if c.name not in scored:
        if s.heldout_top is None:  # _score_heldout: one that explained more was claimable
            return "not scored held out: a term that explained more was claimable"
        return f"not scored held out: {s.heldout_top} candidates explained more"
    gain = scored[c.name][0]
    need = s.min_gain_joining if shapes else s.min_gain
    if not gain >= need:
        joining = " (to join a claimed term)" if shapes else ""
        return f"held-out gain {gain:.2g} < {need:g}{joining}"
    return _too_small(c, min_effect_n)


def _too_small(c: Candidate, min_effect_n: float) -> str:
    if c.effect_peak_n < min_effect_n:
        return f"effect {c.effect_peak_n:.2g} N too small to matter"
    return ""


def _backward(
    search: Data,
    base: Fitted,
    claimed: list[str],
    trials: list[Trial],
    groups: list[dict[str, object]],
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
        model, free, calibrated = _without(search, base, [name], came_with)
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
        groups[:] = [g for g in groups if name not in g["group"]]  # type: ignore[operator]
        base = reduced
    return base


def _without(
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


def _baseline_fit(
    data: Data, fit: FitResult | None, settings: Settings, model: DamperModel, free: tuple[str, ...]
) -> Fitted:
    if fit is None:
        return refit(data, model, free, None, max_nfev=60)
    areas = {(c.clicks, c.gas_clicks, c.setting): (c.a_bc_m2, c.a_bt_m2) for c in fit.clicks}
    start = Fitted(model, (), areas, {}, np.zeros(0), np.zeros(0))
    return refit(data, model, free, start, max_nfev=settings.max_nfev)


def _baseline(data: Data, fit: FitResult | None, settings: Settings, notes: list[str]) -> Fitted:
    """The paper's model (or the given fit's) refitted, with the gas spring rate
    calibrated unless the fit already carries a gas spring or the rate is out of a
    spec's reach (GAS_VOLUME_RANGE)."""
    model = DamperModel(data.prob.base) if fit is None else fit.model()
    if model.term("gas_spring") is not None or "gas_spring" not in settings.candidates:
        return _baseline_fit(data, fit, settings, model, ())
    with_gas = DamperModel(model.spec, (*model.terms, make_term("gas_spring")), model.values)
    calibrated = _baseline_fit(data, fit, settings, with_gas, (GAS_VOLUME,))
    factor = calibrated.model.value(GAS_VOLUME)
    lo, hi = GAS_VOLUME_RANGE
    if lo <= factor <= hi:
        return calibrated
    notes.append(
        f"the gas spring rate would need a gas volume {factor:.2g}× the spec's, beyond a "
        "spec's error: not calibrated, left to the search"
    )
    return _baseline_fit(data, fit, settings, model, ())


def _gas_spring_is_calibration(
    base: Fitted, claimed: list[str], trials: list[Trial], groups: list[dict[str, object]]
) -> bool:
    """A gas spring claimed at a volume within a spec's error is calibration, not physics.

    The baseline calibrates the gas volume unless the plain model wants it beyond a spec's
    reach (GAS_VOLUME_RANGE); with air in the oil it can (the air softens the stroke), and
    once the air is claimed the gas spring joins at the spec's volume give or take a few
    per cent (0.972x in a CI run): the spec's error, not a second physics. It stays in
    the model, and the verdict lists it under calibration. Edits `claimed`, `trials`
    and `groups`."""
    if "gas_spring" not in claimed:
        return False
    lo, hi = GAS_VOLUME_RANGE
    factor = base.model.value(GAS_VOLUME)
    if not lo <= factor <= hi:
        return False
    claimed.remove("gas_spring")
    for f in trials:
        if f.claimed and f.physics == "gas_spring":
            f.claimed = False
            f.why_not = (
                f"a gas volume {factor:.3g}x the spec's is within a spec's error: "
                "calibration, not physics"
            )
    groups[:] = [g for g in groups if "gas_spring" not in cast(list[str], g["group"])]
    return True


def calibration_rows(
    spec: DamperSpec, fitted: Fitted, gas_calibrated: bool, share: float
) -> list[CalibrationRow]:
    """The spec's values against what the recording calibrated them to; the gas volume
    when the baseline calibrated it (not when a claimed gas spring moved it)."""
    got = fitted.model.spec
    rows = [
        CalibrationRow(
            key,
            spec.value(key),
            got.value(key),
            fitted.globals_sd.get(key, math.nan),
            spec_global(key).unit,
            share,
            spec_global(key).fallback,
            spec_global(key).tolerance,
        )
        for key in fitted.globals
    ]
    if gas_calibrated:
        v0 = spec.gas_volume_m3
        sd = fitted.term_sd.get(GAS_VOLUME, math.nan)
        rows.append(
            CalibrationRow(
                "gas_volume_m3", v0, v0 * fitted.model.value(GAS_VOLUME), v0 * sd, "m³", share
            )
        )
    return rows


def _round(
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
    limit = _effect_limit(binned, force_peak, s)
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
    scored = _score_heldout(
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
                parameters=_parameters(c.fitted, c.name),
                ambiguous_with=amb,
                why_not="" if c is best else (reasons[c.name] or "another term explained more"),
            )
        )
    return found, best, [c.name for c in pool]


def decide(
    cands: Sequence[Candidate],
    screened: Sequence[Candidate],
    scored: Mapping[str, tuple[float, str]],
    reasons: Mapping[str, str],
    s: Settings,
) -> tuple[Candidate | None, list[Candidate], dict[str, list[str]]]:
    """A round's outcome from its candidates' reasons (why_not, "" when claimable) and
    held-out scores: the claimed candidate (None: none), the claimable ones it was chosen
    from, and per candidate the claimed one when the verdict cannot tell them apart."""
    passing = [c for c in screened if not reasons[c.name]]
    named = [c for c in passing if c.name != OPEN_SET]
    pool = named or passing
    # Of the claimable, the one the full refit says explains most (its LR): held-out
    # gains of near-tied candidates come from short refits and are noisier.
    best = max(pool, key=lambda c: c.lr) if pool else None
    alike_with: dict[str, list[str]] = {}
    for c in cands:
        if best is not None and c is not best and c.p_value < s.alpha:
            # Alike: the same shape explained, and held out it leaves about as much.
            gain = scored.get(c.name, (math.nan, ""))[0]
            rest, rest_best = 1 - gain, 1 - scored[best.name][0]
            same = _cosine(c.explained, best.explained) > s.alike_cosine
            if same and rest <= s.alike_rest_ratio * rest_best + s.alike_rest_margin:
                alike_with[c.name] = [best.name]
    return best, pool, alike_with


def _score_heldout(
    top: Sequence[Candidate],
    cands: Sequence[Candidate],
    base: Fitted,
    rnd: int,
    s: Settings,
    limit: float,
    shapes: Sequence[tuple[str, FloatArray]],
    x: FloatArray,
    refused: Mapping[str, str],
    fold_list: list[Fold],
    report: Progress,
    workers: Workers,
) -> dict[str, tuple[float, str]]:
    """The held-out gains (and folds in words) of the candidates of `top` (p < alpha,
    largest LR first) whose gain decides something, scored in that order, and only those:
    a fold refit is most of a round's work (five refits a candidate, beside 14 candidate
    refits in all), and most candidates are refused on their full fit alone.

    What the gain decides, and so what is scored:
    - whether a candidate is claimable: only for one every other rule lets pass (why_not
      with scored=None). A candidate another rule refuses is refused whatever its gain;
    - which is claimed: the claimable one with the largest LR (a named term before the
      open set's). So the candidates every other rule lets pass are scored in LR order
      until one passes; those below it cannot be claimed this round. When that one is a
      calibration, every physics term that could pass is scored too (a physics term that
      passed but lost to a calibration gets the next round: `gated`'s `outranked`);
    - which candidates the verdict cannot tell from the claimed one: those whose explained
      shape has a cosine above alike_cosine with its, each scored.
    So the claim, the groups, `passed` and every claimed figure are those of scoring them
    all; a candidate left unscored has no gain (None in DIAG.json) and its first reason.
    Each candidate's gain is the same asked alone or with others (HeldOut)."""
    if not top:
        return {}
    if not fold_list:
        return {c.name: (0.0, "no held-out split") for c in top}
    held = HeldOut(fold_list, base, s.fold_nfev, workers)
    scored: dict[str, tuple[float, str]] = {}

    def score(batch: Sequence[Candidate]) -> None:
        batch = [c for c in batch if c.name not in scored]
        if batch:
            names = ", ".join(c.name for c in batch)
            report(f"round {rnd}: held out, {names}", 0.1 + 0.8 * (rnd - 0.3) / s.max_rounds)
            scored.update(zip((c.name for c in batch), held.gains(batch), strict=True))

    def claimable(c: Candidate) -> bool:
        return not why_not(c, scored, s, limit, shapes, x, refused)

    could = [c for c in top if not why_not(c, None, s, limit, shapes, x, refused)]
    best = None
    named = [c for c in could if c.name != OPEN_SET]
    for group in (named, [c for c in could if c.name == OPEN_SET]):
        for c in group:
            score([c])
            if claimable(c):
                best = c
                break
        if best is not None:
            break
    if best is None:
        return scored
    if best.name in CALIBRATIONS:
        score([c for c in could if c.name not in CALIBRATIONS and c.name != OPEN_SET])
    score(
        [c for c in top if c is not best and _cosine(c.explained, best.explained) > s.alike_cosine]
    )
    return scored


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


def _effect_limit(binned: Sequence[BinnedTest], force_peak: float, s: Settings) -> float:
    """The least effect that matters: 0.1 % of the peak force, and 3 noise σ of a phase
    mean under the current model (a misfit inflates the scatter)."""
    mean_noise = float(np.sqrt(np.mean(np.concatenate([b.mean_var for b in binned]))))
    return max(s.min_effect_share * force_peak, 3 * mean_noise)


def _final_refit(
    data: Data,
    base: Fitted,
    claimed: list[str],
    trials: list[Trial],
    groups: list[dict[str, object]],
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
    limit = _effect_limit(data.binned(base.residual), force_peak, s)
    why: dict[str, str] = {}
    for n in claimed:
        term = base.model.term(n)
        if term is None:
            continue
        odd = term.implausible(base.model.local_values(term), base.model.spec)
        if odd:
            why[n] = f"refitted on every test it is not physical: {odd}"
            continue
        pinned = _at_range_end(base, term)
        if pinned:
            why[n] = f"refitted on every test it is not an estimate: {pinned}"
            continue
        if not _moved_off(base, term):
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
        groups[:] = [g for g in groups if not set(idle) & set(cast(list[str], g["group"]))]
        kept, free, calibrated = _without(data, base, idle, came_with)
        for n in idle:
            came_with.pop(n, None)
        nfev = s.final_nfev if claimed else s.max_nfev
        base = refit(data, kept, free, base, max_nfev=nfev, calibrated=calibrated)
    for f in trials:
        if f.claimed:
            f.parameters = _parameters(base, f.physics)
    return base


def diagnose(
    tests: Sequence[TestData],
    fit: FitResult | None = None,
    settings: Settings | None = None,
    progress: Progress | None = None,
    spec_path: str | None = None,
    workers: int = 1,
) -> Diagnosis:
    """`workers`: processes for the search's independent refits (workers.py); the
    diagnosis is the same with any number."""
    with Workers(workers) as pool:
        return _diagnose(tests, fit, settings, progress, spec_path, pool)


def _diagnose(
    tests: Sequence[TestData],
    fit: FitResult | None,
    settings: Settings | None,
    progress: Progress | None,
    spec_path: str | None,
    workers: Workers,
) -> Diagnosis:
    s = settings or Settings()
    wall0 = time.perf_counter()

    def report(stage: str, fraction: float) -> None:
        if progress is not None:
            progress(stage, fraction)

    report("prepare", 0.0)
    tests, spikes = remove_spikes(tests)
    sensor = [spikes.sentence()] if spikes is not None else []
    prepared, notes = prepare_tests(list(tests), s.objective_rate_hz, phase_locked=True)
    if not prepared:
        raise FitError(
            "no usable test to diagnose (each needs motion, force and 20 samples): "
            + "; ".join(notes[:3])
            + (f"; and {len(notes) - 3} more" if len(notes) > 3 else "")
        )
    # The mismatch test weighs each phase's mean against its scatter from cycle to
    # cycle: a test of fewer than two cycles has no scatter to weigh against.
    few = [p for p in prepared if whole_cycles(p.data) < 2]
    short = [
        ShortTest(m.index, m.clicks, m.frequency_hz, whole_cycles(p.data))
        for p in few
        for m in (p.data.meta,)
    ]
    spec = fit.spec() if fit is not None else load_spec(spec_path)
    # As `fit` does: each area's trend follows the adjuster on its path, which only the
    # spec names, so a spec of another damper's adjusters would misread every click.
    where = fit.spec_file() if fit is not None else spec_path or default_spec_path()
    check_adjusters(tests, spec, Path(where))
    if len(few) == len(prepared):
        return _untestable(few, short, fit, spec, s, notes, sensor, wall0)
    prepared = [p for p in prepared if whole_cycles(p.data) >= 2]
    data = Data.build(spec, prepared, s.full_rate_hz)
    rng = np.random.default_rng(s.seed)
    report("baseline fit", 0.05)
    base = _baseline(data, fit, s, notes)
    baseline = base
    base_means, binned = binned_means(data, base.residual)
    mismatch = mismatch_test(binned, rng, s.n_boot)
    location = locate(data, binned, s)
    search = search_subset(data, s.search_clicks)
    fold_list = folds(search)
    force_peak = float(np.max(np.abs(data.prob.f)))
    trials: list[Trial] = []
    claimed: list[str] = []
    shapes: list[tuple[str, FloatArray]] = []
    groups: list[dict[str, object]] = []
    came_with: dict[str, tuple[str, ...]] = {}  # claimed term -> spec values freed with it
    if search is not data:
        base = refit(search, base.model, base.free, base, max_nfev=s.max_nfev)
        base_means, binned = binned_means(search, base.residual)
    # A term in the baseline (the fit's, or the calibrated gas spring) is not a candidate.
    present = {t.name for t in base.model.terms}
    remaining = [c for c in s.candidates if c not in present]
    remaining += [c for c in s.calibrations if not set(CALIBRATIONS[c]) <= set(base.globals)]
    left = mismatch
    outranked: list[str] = []  # physics that passed every rule but lost to a calibration
    rnd = 0
    while rnd < s.max_rounds:
        rnd += 1
        remaining = gated(remaining, left, claimed, outranked, s)
        if not remaining:
            break
        if rnd > 1:
            # The null of this round, refitted with the candidates' budget: a term must
            # beat more iterations of the model it would join, not a less converged one.
            base = refit(search, base.model, base.free, base, max_nfev=s.max_nfev)
            base_means, binned = binned_means(search, base.residual)
        found, best, passed = _round(
            search,
            base,
            base_means,
            binned,
            remaining,
            rnd,
            s,
            rng,
            fold_list,
            force_peak,
            shapes,
            report,
            workers,
        )
        # A calibration candidate's trial is not physics: DIAG.json's findings hold the
        # library's terms; a calibration the search took is a row of verdict.calibration.
        trials += [f for f in found if f.physics not in CALIBRATIONS]
        if best is None:
            break
        outranked = (
            [n for n in passed if n != best.name and n not in CALIBRATIONS]
            if best.name in CALIBRATIONS
            else []
        )
        if best.name not in CALIBRATIONS:  # a calibration taken joins the model only
            best_f = next(f for f in trials if f.physics == best.name and f.round == rnd)
            alike = [f.physics for f in trials if f.round == rnd and best.name in f.ambiguous_with]
            if alike:
                best_f.ambiguous_with = alike
                group = sorted([best.name, *alike])
                pairs = [separate_by(best.name, a) for a in alike]
                groups.append({"group": group, "separate_by": "; ".join(dict.fromkeys(pairs))})
            claimed.append(best.name)
            came_with[best.name] = tuple(k for k in best.fitted.globals if k not in base.globals)
            shapes.append((best.name, best.explained))
        base = best.fitted
        base_means, binned = binned_means(search, base.residual)
        left = mismatch_test(binned, rng, s.n_boot)
        remaining = [c for c in remaining if c != best.name]
    if len(claimed) >= 2:
        report("backward check", 0.92)
        base = _backward(
            search, base, claimed, trials, groups, fold_list, rng, s, came_with, workers
        )
    report("scores", 0.95)
    if claimed or search is not data:
        base = _final_refit(data, base, claimed, trials, groups, s, force_peak, came_with)
    gas_calibrated = GAS_VOLUME in baseline.free or _gas_spring_is_calibration(
        base, claimed, trials, groups
    )
    before, after = _e_t(data, baseline), _e_t(data, base)
    scores = [
        TestScore(p.data.meta.index, p.data.meta.clicks, p.data.meta.frequency_hz, b, a)
        for p, b, a in zip(data.prepared, before, after, strict=True)
    ]
    _, final_binned = binned_means(data, base.residual)
    remaining_stat = mismatch_test(final_binned, rng, s.n_boot)
    unexplained = (
        locate(data, final_binned, s) if remaining_stat.p_value < s.alpha else Location([], {})
    )
    # -- physics outside the library (issue 45): describe what is left, try a form for it
    described = []
    if unexplained.regions:
        report("unexplained: described", 0.97)
        limit = _effect_limit(final_binned, force_peak, s)
        rms = remaining_stat.structured_rms_n
        described = [discover(data, base, final_binned, unexplained, rms, s, limit)]
    # -- end of the hook
    freqs = {round(p.data.meta.frequency_hz, 3) for p in data.prepared}
    report("done", 1.0)
    return Diagnosis(
        mismatch=mismatch,
        location=location,
        trials=trials,
        claimed=claimed,
        indistinguishable=groups,
        unexplained=unexplained,
        remaining=remaining_stat,
        tests=scores,
        baseline=baseline,
        final=base,
        data=data,
        notes=notes,
        wall_s=time.perf_counter() - wall0,
        single_frequency=len(freqs) == 1,
        calibration=calibration_rows(
            load_spec(fit.spec_file()) if fit else spec, base, gas_calibrated, s.calibration_share
        ),
        settings=s,
        sensor=sensor,
        short_tests=short,
        described=described,
    )


def _untestable(
    prepared: list[PreparedTest],
    short: list[ShortTest],
    fit: FitResult | None,
    spec: DamperSpec,
    s: Settings,
    notes: list[str],
    sensor: list[str],
    wall0: float,
) -> Diagnosis:
    """Every test shorter than two cycles: the model is fitted and drawn (the residual is
    there to see), but with no cycle-to-cycle scatter there is nothing to test it against,
    so no statistic is reported and no term is tried."""
    data = Data.build(spec, prepared, s.full_rate_hz)
    base = _baseline(data, fit, s, notes)
    nan = math.nan
    untested = MismatchStat(nan, nan, nan, nan, nan, 0.0)
    e_t = _e_t(data, base)
    scores = [
        TestScore(p.data.meta.index, p.data.meta.clicks, p.data.meta.frequency_hz, e, e)
        for p, e in zip(prepared, e_t, strict=True)
    ]
    freqs = {round(p.data.meta.frequency_hz, 3) for p in prepared}
    return Diagnosis(
        mismatch=untested,
        location=Location([], {}),
        trials=[],
        claimed=[],
        indistinguishable=[],
        unexplained=Location([], {}),
        remaining=untested,
        tests=scores,
        baseline=base,
        final=base,
        data=data,
        notes=notes,
        wall_s=time.perf_counter() - wall0,
        single_frequency=len(freqs) == 1,
        calibration=[],
        settings=s,
        sensor=sensor,
        short_tests=short,
    )
