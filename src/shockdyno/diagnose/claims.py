"""The claim rules: why a candidate is not claimed (`why_not`), which one a round claims
(`decide`), which candidates are scored held out (`Judge.score_heldout`), and what tells two
look-alikes apart (`separate_by`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.candidates import Candidate, Fold, HeldOut
from shockdyno.diagnose.cycles import BinnedTest
from shockdyno.diagnose.fitting import CALIBRATIONS, Fitted
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.stats import AT_BOUND, at_bound
from shockdyno.diagnose.workers import Workers
from shockdyno.fit.parameters import spec_global
from shockdyno.model.composite import Term
from shockdyno.model.terms import LIBRARY

FloatArray = NDArray[np.float64]
Progress = Callable[[str, float], None]


def open_set(name: str) -> bool:
    """Whether candidate `name` is a generic form (Term.open_set), claimed only when no
    named term is."""
    term = LIBRARY.get(name)
    return term is not None and term.open_set


# What separates two candidates that explain the same shape of residual.
def separate_by(a: str, b: str) -> str:
    """What would tell terms a and b apart (Term.separated_by, written on one of the two)."""
    ca, cb = LIBRARY.get(a), LIBRARY.get(b)
    said = (ca.separated_by.get(b) if ca else None) or (cb.separated_by.get(a) if cb else None)
    return said or DEFAULT_SEPARATE


DEFAULT_SEPARATE = "tests at other frequencies, amplitudes and gas pressures"


def cosine(a: FloatArray, b: FloatArray) -> float:
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    return float(a @ b / (na * nb)) if na > 0 and nb > 0 else 0.0


def moved_off(fitted: Fitted, term: Term) -> bool:
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


def left_off(fitted: Fitted, names: Sequence[str]) -> tuple[str, ...]:
    """The free parameters (qualified) of the terms `names` that `fitted` left at their off
    values (within a thousandth of their scale): what a claim was made without, and the
    form the final refit judges it in again when, refitted with them free, it would leave
    the verdict (Search.as_claimed)."""
    out: list[str] = []
    for n in names:
        term = fitted.model.term(n)
        if term is None:
            continue
        for p in term.params():
            key = term.qualified(p.name)
            if key in fitted.free and at_bound(fitted.model.value(key), p.off, p.scale):
                out.append(key)
    return tuple(out)


def at_range_end(fitted: Fitted, term: Term) -> str:
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
            if bound != p.off and at_bound(value, bound, p.scale):
                return f"its {p.name} sits at the {end} end of its range ({bound:.4g} {p.unit})"
    return ""


def _beyond_noise(value: float, ref: float, sd: float, scale: float) -> bool:
    """Whether a fitted value sits off `ref` by more than 3σ and a thousandth of its scale
    (a value that is not finite has moved)."""
    noise = 3 * sd if math.isfinite(sd) else 0.0
    return not math.isfinite(value) or abs(value - ref) > max(noise, AT_BOUND * scale)


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


def own_force_small(c: Candidate, min_effect_n: float) -> str:
    """Why candidate `c`'s own force (the model less the same with the term at its off
    values) is too small to matter ("" when it is not): its gain, then, is the refit's of
    everything beside it."""
    if c.own_peak_n < min_effect_n:
        return (
            f"its own force peaks at {c.own_peak_n:.2g} N, too small to matter: the gain "
            "is the refit's"
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
    rule but the held-out gain's (what `Search.round` asks before it scores a candidate held
    out: a candidate one of them refuses is refused whatever its gain)."""
    if refused and refused.get(c.name):
        return refused[c.name]
    for name, shape in shapes:
        if cosine(c.explained, shape) > s.same_shape:
            return f"the same shape as {name}, already claimed"
    if c.name in CALIBRATIONS:
        why = _calibration_idle(c, min_effect_n)
        if why:
            return why
    term = c.fitted.model.term(c.name)
    if term is not None:
        odd = term.implausible(c.fitted.model.local_values(term), c.fitted.model.spec)
        odd = odd or c.implausible_on
        if odd:
            return f"not physical: {odd}"
        if x is not None:
            unplaced = term.unplaced(c.fitted.model.local_values(term), x)
            if unplaced:
                return f"not placed: {unplaced}"
        if not moved_off(c.fitted, term):
            return "its parameters stay at their off values: the gain is the refit's"
        small = own_force_small(c, min_effect_n)
        if small:
            return small
        pinned = at_range_end(c.fitted, term)
        if pinned:
            return f"not an estimate: {pinned}"
        if c.in_place < s.min_in_place and c.spread < s.placeless_share:  # in_place.py
            return (
                f"not its physics: it removes {100 * max(c.in_place, 0.0):.0f} % of the "
                "structure where its own force acts (a term that is the physics left out "
                f"takes {100 * s.min_in_place:.0f} % or more there)" + _within_noise(c, s)
            )
    if c.p_value >= s.alpha:
        return f"p = {c.p_value:.3g} ≥ {s.alpha:g}"
    if scored is None:
        return _too_small(c, min_effect_n)
    if c.name not in scored:
        if s.heldout_top is None:  # Judge.score_heldout: one that explained more was claimable
            return "not scored held out: a term that explained more was claimable"
        return f"not scored held out: {s.heldout_top} candidates explained more"
    gain = scored[c.name][0]
    need = s.min_gain_joining if shapes else s.min_gain
    if not gain >= need:
        joining = " (to join a claimed term)" if shapes else ""
        return f"held-out gain {gain:.2g} < {need:g}{joining}"
    if c.in_place < s.min_in_place and not gain >= s.unnamed_min_gain:  # spread: in_place.py
        return (
            f"not its physics: its own force acts in {100 * c.spread:.0f} % of the cycle, "
            f"where it removes {100 * max(c.in_place, 0.0):.0f} % of the structure, and held "
            f"out it removes {100 * max(gain, 0.0):.0f} % (a discovered term is claimed at "
            f"{100 * s.unnamed_min_gain:.0f} %)"
        )
    return _too_small(c, min_effect_n)


# A share this many of its noise's standard deviations from the threshold is one the
# recording decides; nearer, noise alone could put it on the other side.
IN_PLACE_SDS = 2.0


def _within_noise(c: Candidate, s: Settings) -> str:
    """Said of a share refused under the threshold that its noise could have put over it."""
    if c.in_place_sd <= 0 or c.in_place + IN_PLACE_SDS * c.in_place_sd < s.min_in_place:
        return ""
    return (
        f"; its noise moves that by ±{100 * c.in_place_sd:.0f} %, so this recording cannot "
        "tell whether it is the physics left out"
    )


def borderline(c: Candidate, s: Settings) -> str:
    """Said of a claimed term whose share where its own force acts (in_place.py) is over
    the threshold by less than its noise could move it ("" otherwise)."""
    if c.spread >= s.placeless_share or c.in_place_sd <= 0:
        return ""
    if c.in_place - IN_PLACE_SDS * c.in_place_sd >= s.min_in_place:
        return ""
    return (
        f"borderline: where its own force acts it removes {100 * c.in_place:.0f} ± "
        f"{100 * c.in_place_sd:.0f} % of the structure, and a term that is the physics left "
        f"out takes {100 * s.min_in_place:.0f} % or more there; another recording of the "
        "same damper could go either way"
    )


def _too_small(c: Candidate, min_effect_n: float) -> str:
    if c.effect_peak_n < min_effect_n:
        return f"effect {c.effect_peak_n:.2g} N too small to matter"
    return ""


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
    named = [c for c in passing if not open_set(c.name)]
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
            same = cosine(c.explained, best.explained) > s.alike_cosine
            if same and rest <= s.alike_rest_ratio * rest_best + s.alike_rest_margin:
                alike_with[c.name] = [best.name]
    return best, pool, alike_with


@dataclass(frozen=True)
class Judge:
    """One round's claim rules and held-out scoring: what `why_not` reads beside each
    candidate's own fit (the least effect that matters, what each claimed term explained,
    the positions the data cover, the consistency checks' refusals) and what a held-out
    score needs (the model so far, the folds, the workers)."""

    rnd: int
    s: Settings
    limit: float  # effect_limit
    shapes: Sequence[tuple[str, FloatArray]]
    x: FloatArray | None
    refused: Mapping[str, str]
    base: Fitted
    folds: list[Fold]
    report: Progress
    workers: Workers

    def why_not(self, c: Candidate, scored: dict[str, tuple[float, str]] | None) -> str:
        """why_not with this round's rules."""
        return why_not(c, scored, self.s, self.limit, self.shapes, self.x, self.refused)

    def score_heldout(self, top: Sequence[Candidate]) -> dict[str, tuple[float, str]]:
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
        if not self.folds:
            return {c.name: (0.0, "no held-out split") for c in top}
        s = self.s
        held = HeldOut(self.folds, self.base, s.fold_nfev, self.workers)
        scored: dict[str, tuple[float, str]] = {}

        def score(batch: Sequence[Candidate]) -> None:
            batch = [c for c in batch if c.name not in scored]
            if batch:
                names = ", ".join(c.name for c in batch)
                self.report(
                    f"round {self.rnd}: held out, {names}",
                    0.1 + 0.8 * (self.rnd - 0.3) / s.max_rounds,
                )
                scored.update(zip((c.name for c in batch), held.gains(batch), strict=True))

        def claimable(c: Candidate) -> bool:
            return not self.why_not(c, scored)

        could = [c for c in top if not self.why_not(c, None)]
        best = None
        named = [c for c in could if not open_set(c.name)]
        if named:
            # The first named one is scored first and most often claimed, and then those
            # alike it are scored too: all refitted in one map (HeldOut.prefetch; the
            # scores are taken below as before, so a guess that proves wrong costs CPU,
            # never a different verdict).
            first = named[0]
            held.prefetch(
                [first]
                + [
                    c
                    for c in top
                    if c is not first and cosine(c.explained, first.explained) > s.alike_cosine
                ]
            )
        for group in (named, [c for c in could if open_set(c.name)]):
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
            score([c for c in could if c.name not in CALIBRATIONS and not open_set(c.name)])
        score(
            [
                c
                for c in top
                if c is not best and cosine(c.explained, best.explained) > s.alike_cosine
            ]
        )
        return scored


def effect_limit(binned: Sequence[BinnedTest], force_peak: float, s: Settings) -> float:
    """The least effect that matters: 0.1 % of the peak force, and 3 noise σ of a phase
    mean under the current model (a misfit inflates the scatter)."""
    mean_noise = float(np.sqrt(np.mean(np.concatenate([b.mean_var for b in binned]))))
    return max(s.min_effect_share * force_peak, 3 * mean_noise)
