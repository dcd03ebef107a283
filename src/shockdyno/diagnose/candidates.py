"""One candidate term: refit with it, test it, score it on held-out tests."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import cast

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.cycles import N_BINS, BinnedTest
from shockdyno.diagnose.data import Data, time_halves
from shockdyno.diagnose.fitting import (
    CALIBRATIONS,
    COMPANIONS,
    RESTARTS,
    Fitted,
    evaluate,
    jacobian_on,
    predict,
    refit,
    train_fold,
)
from shockdyno.diagnose.in_place import acts_share, share_noise_sd, share_where_it_acts
from shockdyno.diagnose.stats import basis, lr_bootstrap
from shockdyno.diagnose.workers import SERIAL, Workers
from shockdyno.fit.parameters import global_parameters, spec_global
from shockdyno.fit.prepare import PreparedTest
from shockdyno.model.composite import DamperModel, Evaluation
from shockdyno.model.params import Param
from shockdyno.model.terms import make_term

FloatArray = NDArray[np.float64]
AREA_SCALE = 1e-6  # areas per mm², like the fit

# A fold's refit may start from the full fit's Jacobian with Broyden's updates (fitting.refit
# warm=True): far fewer model evaluations, but held-out gains that are not the differenced
# ones, and a real seal lost its claim with them (benchmarks/results). Off until they agree.
WARM_FOLDS = False
# A term's refinements (`refined`) are kept at the claims' own default level of significance.
REFINE_ALPHA = 0.01


def with_term(model: DamperModel, name: str, data: Data) -> DamperModel:
    """`model` plus the library term `name` at its nominal ("on") values."""
    term = make_term(name)
    m = DamperModel(model.spec, (*model.terms, term), model.values)
    placed = term.placed(data.prob.inputs.x)  # only the new term's: the rest stay as fitted
    return m.with_values({term.qualified(k): v for k, v in placed.items()})


def default_free(name: str) -> tuple[str, ...]:
    if name in CALIBRATIONS:
        return ()  # spec values, not a term's parameters
    term = make_term(name)
    return tuple(term.qualified(k) for k in term.nesting_free())


def spec_values(data: Data, name: str) -> dict[str, float]:
    """A calibration candidate's values in the spec the search started from."""
    return {k: data.prob.base.value(k) for k in CALIBRATIONS[name]}


def with_calibration(fitted: Fitted, name: str) -> tuple[str, ...]:
    """The spec values a fit calibrates with calibration candidate `name` added."""
    return (*fitted.globals, *(k for k in CALIBRATIONS[name] if k not in fitted.globals))


def companion_keys(fitted: Fitted, name: str) -> tuple[str, ...]:
    """The spec values term `name` frees beside it that `fitted` does not calibrate yet."""
    return tuple(k for k in COMPANIONS.get(name, ()) if k not in fitted.globals)


def best_start(data: Data, model: DamperModel, name: str, base: Fitted) -> DamperModel:
    """The term's start (from its grid) with the least squared error, the rest held."""
    term = model.term(name)
    if term is None or len(term.start_grid()) < 2:
        return model  # one start (or none): nothing to choose, and no need to look
    grid = term.start_grid(evaluate(data, base))
    starts = [model.with_values({term.qualified(k): v for k, v in g.items()}) for g in grid]
    return least_error(data, base, model, starts)


def least_error(
    data: Data, base: Fitted, like: DamperModel, models: Iterable[DamperModel]
) -> DamperModel:
    """Of `models` (each `like` but for some values), the one with the least squared
    error on `data` with `base`'s areas held (`like` when there are none)."""
    bc, bt = base.area_vectors(data)
    prob = data.prob.for_model(like)
    best, best_sse = like, math.inf
    for m in models:
        r = prob.force(m, bc, bt) - prob.f
        sse = float(r @ r)
        if sse < best_sse:
            best, best_sse = m, sse
    return best


def calibration_start(data: Data, base: Fitted, name: str) -> DamperModel:
    """`base`'s model with calibration `name`'s values at the start (its own value or one
    of `SpecGlobal.starts`, each within its range) with the least squared error, the
    rest held."""
    keys = [k for k in CALIBRATIONS[name] if k not in base.globals]
    return spec_start(data, base, base.model, keys)


def restarts(data: Data, base: Fitted, name: str) -> list[DamperModel]:
    """Calibration `name`'s second starts (fitting.RESTARTS): the values it trades with at
    the drawing's (within any range `base` holds them to), its own at each of its
    `SpecGlobal.starts`. None for a calibration that trades with nothing."""
    traded = RESTARTS.get(name, ())
    if not traded:
        return []
    drawing = data.prob.base
    back = {}
    for k in traded:
        lo, hi = base.limits.get(k, (-math.inf, math.inf))
        back[k] = min(max(drawing.value(k), lo), hi)
    out = []
    for k in CALIBRATIONS[name]:
        g = spec_global(k)
        lo, hi = g.bounds(drawing.value(k))
        for v in g.starts:
            spec = base.model.spec.with_values({**back, k: min(max(v, lo), hi)})
            out.append(base.model.with_spec(spec))
    return out


def spec_start(data: Data, base: Fitted, model: DamperModel, keys: Sequence[str]) -> DamperModel:
    """`model` with spec values `keys` at the start (each its own value or one of
    `SpecGlobal.starts`, within its range) with the least squared error, the rest held:
    a seal's travel fitted from the spec's 0 stays there (the force hardly moves with
    the first µm), where the recording's seal turns over tenths of a mm."""
    spec = model.spec
    choices = []
    for k in keys:
        g = spec_global(k)
        lo, hi = g.bounds(spec.value(k))
        choices.append(sorted({spec.value(k), *(min(max(v, lo), hi) for v in g.starts)}))
    if all(len(c) < 2 for c in choices):
        return model
    starts = (
        model.with_spec(spec.with_values(dict(zip(keys, values, strict=True))))
        for values in itertools.product(*choices)
    )
    return least_error(data, base, model, starts)


def fit_binned_jacobian(data: Data, fitted: Fitted) -> FloatArray:
    """`binned_jacobian`'s matrix taken from the calibration's own Jacobian at the fit
    (`jacobian_on`), which has `data`'s tests and clicks: the same derivatives at the same
    point, differenced there already, where working them out again cost as many model
    evaluations (a chamber integration each, where one runs). Otherwise
    `binned_jacobian`'s."""
    jac = jacobian_on(data, fitted)
    if jac is None:
        return binned_jacobian(data, fitted)[0]
    declared = dict(fitted.model.param_list())
    scales = [g.scale for g in global_parameters(fitted.model.spec, fitted.globals)]
    scales += [declared[q].scale for q in fitted.free]
    scales += [AREA_SCALE] * (2 * data.prob.n_groups)
    return data.bin_matrix(jac[: data.prob.size] * np.asarray(scales, dtype=float))


def binned_jacobian(data: Data, fitted: Fitted) -> tuple[FloatArray, int]:
    """d(force)/d(parameter) in the binned space at a fit: globals, the fit's free term
    parameters, then every (click, direction) area; and how many columns precede the
    areas. Columns are per unit of each parameter's scale."""
    model = fitted.model
    prob = data.prob.for_model(model)
    bc, bt = fitted.area_vectors(data)
    f0 = fitted.force
    cols: list[FloatArray] = []
    for g in global_parameters(model.spec, fitted.globals):
        h = 1e-4 * g.scale
        moved = model.with_spec(model.spec.with_values({g.name: g.value + h}))
        cols.append((prob.force(moved, bc, bt) - f0) / h * g.scale)
    declared = dict(model.param_list())
    for q in fitted.free:
        p = declared[q]
        v = model.value(q)
        h = 1e-3 * p.scale
        if v + h > p.hi:
            h = -h
        moved = model.with_values({q: v + h})
        cols.append((prob.force(moved, bc, bt) - f0) / h * p.scale)
    ng = len(cols)
    n = prob.n_groups
    h_area = np.maximum(1e-3 * np.concatenate([bc, bt]), 1e-10)
    area_cols = np.zeros((prob.size, 2 * n))
    rows = np.arange(prob.size)
    if any(t.stateful for t in model.terms):
        # A state carries an area's effect past reversal: columns from one step of the
        # compression areas, then one of the rebound areas (as fit/calibrate.py does).
        zero = np.zeros(n)
        for side, (dbc, dbt) in enumerate(((h_area[:n], zero), (zero, h_area[n:]))):
            dr = prob.force(model, bc + dbc, bt + dbt) - f0
            col = side * n + prob.group
            area_cols[rows, col] = dr / h_area[col] * AREA_SCALE
    else:
        pid = prob.problem
        ok = pid < 2 * n
        dr = prob.force(model, bc + h_area[:n], bt + h_area[n:]) - f0
        area_cols[rows[ok], pid[ok]] = dr[ok] / h_area[pid[ok]] * AREA_SCALE
    stacked = np.column_stack([*cols, area_cols]) if cols else area_cols
    return data.bin_matrix(stacked), ng


def own_force(data: Data, fitted: Fitted, name: str) -> FloatArray | None:
    """What the term itself does to the force: the fitted model less the same model with
    the term's parameters at their off values, areas and globals held. (Not the term's
    force component: a channel delay acts on the motion and a chamber on the pressure,
    and neither adds a component of its own; a delay's component was 1e-10 N while it
    moved the force by 586 N.) None when the term is absent or the fit has no areas for
    some of these clicks."""
    areas = fitted.covered_areas(data)
    if areas is None:
        return None
    if name in CALIBRATIONS:  # the spec's own values (those it calibrates from: 0)
        off = fitted.model.with_spec(fitted.model.spec.with_values(spec_values(data, name)))
    else:
        term = fitted.model.term(name)
        if term is None:
            return None
        off = fitted.model.with_values({term.qualified(p.name): p.off for p in term.params()})
    bc, bt = areas
    prob = data.prob.for_model(fitted.model, fitted.free)  # one sample rate for both
    on_force = prob.force(fitted.model, bc, bt)
    off_force = prob.force(off, bc, bt)
    return on_force - off_force


def own_binned(data: Data, fitted: Fitted, name: str) -> FloatArray | None:
    """The term's own force (`own_force`) per (test, phase bin); None as own_force."""
    own = own_force(data, fitted, name)
    return None if own is None else data.bin_matrix(own[:, None])[:, 0]


def own_peak(data: Data, fitted: Fitted, name: str) -> float:
    """The largest phase mean of the term's own force (`own_force`); ∞ when that cannot
    be worked out, so no "too small" refusal rests on it."""
    binned = own_binned(data, fitted, name)
    if binned is None:
        return math.inf
    return float(np.max(np.abs(binned))) if binned.size else 0.0


def binned_means(data: Data, residual: FloatArray) -> tuple[FloatArray, list[BinnedTest]]:
    binned = data.binned(residual)
    return np.concatenate([b.mean for b in binned]), binned


@dataclass(frozen=True)
class Candidate:
    name: str
    fitted: Fitted
    lr: float  # drop in Σ phase-mean² (N²) from the baseline refit
    p_value: float
    effect_rms_n: float  # RMS change of the model force the term makes on these tests
    effect_peak_n: float  # largest change of a phase mean: the effect where the term acts
    explained: FloatArray  # baseline phase means minus the candidate's
    heldout_gain: float = math.nan
    heldout_detail: str = ""
    # Largest phase mean of the term's own force component: what the term itself adds,
    # apart from what refitting the areas and globals beside it moved.
    own_peak_n: float = math.inf
    # A calibration candidate's spec values before it moved them (the base spec's).
    spec_values: dict[str, float] = field(default_factory=dict)
    # Why the force the term makes on these tests is not physics (Term.implausible_on).
    implausible_on: str = ""
    # Of the structure where the term's own force acts, the share its refit removes
    # (in_place.py; 1: not judged, as for a calibration).
    in_place: float = 1.0
    # How far the recording's noise moves `in_place` (in_place.share_noise_sd; 0: not read).
    in_place_sd: float = 0.0
    # The share of the (test, phase bin) cells where a term of the cycle's own force acts
    # (in_place.acts_share; 0 for heat and calibrations): spread over most of them, the
    # term has no place apart from the valves' (claims.why_not judges it held out too).
    spread: float = 0.0


def try_candidate(
    data: Data,
    base: Fitted,
    base_means: FloatArray,
    name: str,
    noise: FloatArray,
    max_nfev: int,
    min_effect_n: float = 0.0,
) -> Candidate:
    """Candidate `name` refitted beside `base` and tested against it. `min_effect_n`: the
    least force that matters (claims.effect_limit); a part of the term whose own force
    stays below it is held off (`Term.faint`)."""
    jac_here: FloatArray | None = None  # the Jacobian at `fitted`, where worked out already
    if name in CALIBRATIONS:
        calibrated = with_calibration(base, name)
        fitted = refit(
            data,
            calibration_start(data, base, name),
            base.free,
            base,
            max_nfev=max_nfev,
            calibrated=calibrated,
            bounds_from=base.model.spec,
        )
        for start in restarts(data, base, name):
            other = refit(
                data,
                start,
                base.free,
                base,
                max_nfev=max_nfev,
                calibrated=calibrated,
                bounds_from=base.model.spec,
            )
            if float(other.residual @ other.residual) < float(fitted.residual @ fitted.residual):
                fitted = other
        new_cols = [i for i, k in enumerate(calibrated) if k not in base.globals]
    else:
        model = best_start(data, with_term(base.model, name, data), name, base)
        mine = default_free(name)
        extra = companion_keys(base, name)
        model = spec_start(data, base, model, extra)
        calibrated = (*base.globals, *extra)
        fitted = refit(
            data, model, (*base.free, *mine), base, max_nfev=max_nfev, calibrated=calibrated
        )
        # A side the data cannot place (a top-out met only in the stroke's last 10 %)
        # goes off, then a shape the fit leaves undetermined is held, and each time the
        # term is fitted again without it: refusing the whole term for such a side lost a
        # bump stop placed to 0.02 mm (199 N for 200, held-out gain 1.00), and the search
        # took a gas spring and a position force instead.
        rules: tuple[Callable[[Fitted], dict[str, float]], ...] = (
            lambda f: _unseen(data, f, name),
            lambda f: _undetermined(f, name),
            lambda f: _faint(data, f, name, min_effect_n),
        )
        for held_by in rules:
            held = held_by(fitted)
            if held:
                mine = tuple(k for k in mine if k not in held)
                model = fitted.model.with_values(held)
                fitted = refit(data, model, (*base.free, *mine), fitted, max_nfev, calibrated)
        fitted, mine, jac_here = refined(
            data, base, fitted, name, mine, noise, max_nfev, calibrated
        )
        ahead = len(fitted.globals) + len(fitted.free)  # the Jacobian's globals, then terms
        new_cols = list(range(ahead - len(mine), ahead))
        new_cols += [i for i, k in enumerate(fitted.globals) if k in extra]
    means, _ = binned_means(data, fitted.residual)
    lr = float(np.sum(base_means**2) - np.sum(means**2))
    p = 1.0  # a refit that explains no more than the baseline: no Jacobian needed
    if lr > 0:
        jac = jac_here if jac_here is not None else fit_binned_jacobian(data, fitted)
        null = np.array([i for i in range(jac.shape[1]) if i not in set(new_cols)], dtype=int)
        p = lr_bootstrap(lr, jac[:, null], jac, noise)
    effect = float(np.sqrt(np.mean((fitted.force - base.force) ** 2)))
    change = data.bin_matrix((fitted.force - base.force)[:, None])[:, 0]
    peak = float(np.max(np.abs(change))) if change.size else 0.0
    own = own_binned(data, fitted, name)
    own_peak_n = math.inf if own is None else float(np.max(np.abs(own), initial=0.0))
    before = spec_values(data, name) if name in CALIBRATIONS else {}
    in_place, in_place_sd, spread = 1.0, 0.0, 0.0
    if own is not None and name not in CALIBRATIONS:
        term = fitted.model.term(name)
        place = "cycle" if term is None else term.place
        before_binned = binned_means(data, base.residual)[1]
        in_place = share_where_it_acts(place, own, before_binned, means)
        if place == "cycle":
            spread = acts_share(own)
            in_place_sd = share_noise_sd(own, before_binned, means, noise)
    return Candidate(
        name, fitted, lr, p, effect, peak, base_means - means, own_peak_n=own_peak_n,
        spec_values=before, implausible_on=seen_implausible(data, fitted, name),
        in_place=in_place, in_place_sd=in_place_sd, spread=spread,
    )  # fmt: skip


def refined(
    data: Data,
    base: Fitted,
    fitted: Fitted,
    name: str,
    mine: tuple[str, ...],
    noise: FloatArray,
    max_nfev: int,
    calibrated: tuple[str, ...],
) -> tuple[Fitted, tuple[str, ...], FloatArray | None]:
    """The term's fit with its `Term.refinements` freed too, where that explains
    significantly more than the fit without them (a bootstrap of its drop in Σ mean²,
    p < REFINE_ALPHA); else the fit as it was. (`mine` grows by what is kept.) Also the
    binned Jacobian at the fit returned where one was worked out (None where not), so the
    candidate's own test need not work it out again.

    The refinements' starts are tried beside the term as fitted and beside each of its own
    starts (`start_grid`, placed on `base`, the model without it): a refinement can be
    most of what the term does where it acts, so the term fitted without it may sit where
    it does nothing (released gas can move the force more than the floor does; beside
    another term the floor alone can be fitted below every pressure the data reach, where
    gas tried from there cannot act). Refitted only from the start with the least squared
    error, where it has less than the fit itself and its step could explain significantly
    more (`_step_p`): on a sweep where the refinement would not act, no refit is paid for."""
    term = fitted.model.term(name)
    extra = term.refinements() if term is not None else {}
    if term is None or not extra:
        return fitted, mine, None
    keys = tuple(term.qualified(k) for k in extra)
    held = tuple(fitted.model.value(k) for k in keys)
    tries = [
        dict(zip(keys, values, strict=True))
        for values in itertools.product(*extra.values())
        if values != held
    ]
    own: list[dict[str, float]] = [{}] + [
        {term.qualified(k): v for k, v in g.items()} for g in term.start_grid(evaluate(data, base))
    ]
    starts = [fitted.model] + [fitted.model.with_values({**o, **t}) for o in own for t in tries]
    start = least_error(data, fitted, fitted.model, starts)
    if start is fitted.model:
        return fitted, mine, None
    means, _ = binned_means(data, fitted.residual)
    jac = fit_binned_jacobian(data, fitted)
    if _step_p(data, fitted, start, means, jac, noise) >= REFINE_ALPHA:
        return fitted, mine, jac
    free = (*fitted.free, *keys)
    more = refit(data, start, free, fitted, max_nfev=max_nfev, calibrated=calibrated)
    after, _ = binned_means(data, more.residual)
    lr = float(np.sum(means**2) - np.sum(after**2))
    if lr <= 0:
        return fitted, mine, jac
    jac_more = fit_binned_jacobian(data, more)
    ahead = len(more.globals) + len(more.free)
    new = set(range(ahead - len(keys), ahead))
    null = np.array([i for i in range(jac_more.shape[1]) if i not in new], dtype=int)
    if lr_bootstrap(lr, jac_more[:, null], jac_more, noise) >= REFINE_ALPHA:
        return fitted, mine, jac
    return more, (*mine, *keys), jac_more


def _step_p(
    data: Data,
    fitted: Fitted,
    start: DamperModel,
    means: FloatArray,
    jac: FloatArray,
    noise: FloatArray,
) -> float:
    """`step_p` of the step from `fitted` to `start` (areas held) in the phase means."""
    bc, bt = fitted.area_vectors(data)
    prob = data.prob.for_model(start)
    moved, _ = binned_means(data, prob.force(start, bc, bt) - prob.f)
    return step_p(means, moved - means, jac, noise)


def step_p(means: FloatArray, step: FloatArray, jac: FloatArray, noise: FloatArray) -> float:
    """p-value of what a refit along `step` (a change of the phase means) could explain of
    the residual means `means`, beyond what the fit's own columns `jac` can: the residual
    projected on the step less its part in their span (to first order, the refit's first
    step), against the same projection of each noise draw. A step that points at noise,
    or at what the fit's parameters already span, is not worth a refit; one that
    overshoots (more squared error than the fit) can still point the right way."""
    q = basis(jac)
    off = step - q @ (q.T @ step)
    size = float(np.linalg.norm(off))
    if size <= 1e-12 * (float(np.linalg.norm(step)) + 1e-300):
        return 1.0
    along = float(means @ off) / size
    return lr_bootstrap(along**2, jac, np.column_stack([jac, off]), noise)


def seen_implausible(data: Data, fitted: Fitted, name: str) -> str:
    """Why the force term `name` makes as `fitted` on `data` is not physics
    (Term.implausible_on; "" when it is, or the term is not in)."""
    term = fitted.model.term(name)
    ev = evaluate(data, fitted) if term is not None else None
    if term is None or ev is None:
        return ""
    return term.implausible_on(fitted.model.local_values(term), fitted.model.spec, ev)


def _unseen(data: Data, fitted: Fitted, name: str) -> dict[str, float]:
    """Where the term as fitted is not placed (`Term.unplaced`), its parameters the data
    do not measure (`Term.unseen`) with their off values, where they are not off already.
    Only then: a side beyond the stroke with no force changes nothing worth a refit."""
    term = fitted.model.term(name)
    if term is None:
        return {}
    local = fitted.model.local_values(term)
    x = data.prob.inputs.x
    if not term.unplaced(local, x):
        return {}
    found = term.unseen(local, x)
    return {term.qualified(k): v for k, v in found.items() if local[k] != v}


def _faint(data: Data, fitted: Fitted, name: str, limit_n: float) -> dict[str, float]:
    """The term's parts whose own force stays below `limit_n` on `data` (`Term.faint`),
    with their off values, where they are not off already."""
    term = fitted.model.term(name)
    if term is None or limit_n <= 0:
        return {}
    local = fitted.model.local_values(term)
    _, v, _ = fitted.model.motion(data.prob.inputs)
    found = term.faint(local, data.prob.inputs.x, v, limit_n)
    return {term.qualified(k): v for k, v in found.items() if local[k] != v}


def freed_shapes(data: Data, fitted: Fitted, names: Sequence[str], max_nfev: int) -> Fitted:
    """`fitted` with the shape parameters (`Param.held_above_sd`) of terms `names` that the
    search held (at their nominal by default, or by `_undetermined`) freed and refitted
    where the data, fitted to the end, tell them (σ within their bound): a candidate's
    short refit, far from the noise, inflates every σ (a held-out bump stop 12 mm deep:
    onset ± 4 mm and n ± 0.99 there, ± 0.02 mm at the end). A shape that moves no sample
    (an off side's n, the loss's speed with no loss) is not tried: with no column of its
    own the solver walks it anywhere. `fitted` itself where none is told."""
    shapes = [(q, p) for q, p in _shapes(fitted, names) if q not in fitted.free]
    if not shapes:
        return fitted
    here = evaluate(data, fitted)
    bounds = {q: p.held_above_sd for q, p in shapes if _moves(data, fitted, q, here)}
    held = list(bounds)
    before = float(fitted.residual @ fitted.residual)
    while held:  # a pass that does not keep all it freed tries fewer
        freed = refit(data, fitted.model, (*fitted.free, *held), fitted, max_nfev)
        told = [k for k in held if freed.term_sd.get(k, math.inf) <= bounds[k]]
        if told == held:
            return fitted if float(freed.residual @ freed.residual) > before else freed
        held = told
    return fitted


def _shapes(fitted: Fitted, names: Sequence[str]) -> list[tuple[str, Param]]:
    """The shape parameters (`Param.held_above_sd`) of terms `names` in `fitted`'s model."""
    return [
        (q, p)
        for q, p in fitted.model.param_list()
        if q.partition(".")[0] in names and math.isfinite(p.held_above_sd)
    ]


def _moves(data: Data, fitted: Fitted, key: str, here: Evaluation | None) -> bool:
    """Whether parameter `key` 10 % off its value moves some sample of `fitted`'s force on
    `data` (`here`) by a hundredth of a newton."""
    value = fitted.model.value(key)
    there = evaluate(data, replace(fitted, model=fitted.model.with_values({key: 1.1 * value})))
    if here is None or there is None:
        return False
    return bool(np.max(np.abs(there.force - here.force), initial=0.0) > 0.01)


def _undetermined(fitted: Fitted, name: str) -> dict[str, float]:
    """The term's free shape parameters (`Param.held_above_sd`) the fit left with a σ above
    their bound, at their nominal values: the term is fitted again without them."""
    # NaN or an infinite σ: not determined either
    return {
        q: p.nominal
        for q, p in _shapes(fitted, [name])
        if q in fitted.free and not fitted.term_sd.get(q, math.inf) <= p.held_above_sd
    }


def _structure(data: Data, residual: FloatArray) -> FloatArray:
    """Per test, the sum over its phase bins of the mean square less its noise variance:
    the structure left (N² · bins)."""
    _, binned = binned_means(data, residual)
    return np.array([float(np.sum(b.mean**2 - b.mean_var)) for b in binned])


# A held-out test counts toward a candidate's gain where the candidate's own force, as
# trained, reaches this share of its largest: vapour on the stiffest click at 1-1.5 Hz is
# judged on those tests, not diluted by the misfit of tests where it does nothing (a
# reference-plant sweep's cavitation removed 4.7 % of all the held-out structure that way).
ACTS_SHARE = 0.1


@dataclass(frozen=True)
class Fold:
    label: str
    train: Data
    test: Data
    # The same split with the left-out tests' first halves (in time) trained on and their
    # second halves predicted: the check for a term that acts on the left-out tests only
    # (vapour on the stiffest click at 1.5 Hz), which the whole split cannot place.
    # None where a left-out test has fewer than four cycles.
    halves: Fold | None = None


def _time_halves(tests: Sequence[PreparedTest]) -> tuple[list[PreparedTest], list[PreparedTest]]:
    """The first and the second halves in time of those tests that have four cycles."""
    pairs = [h for h in map(time_halves, tests) if h is not None]
    return [a for a, _ in pairs], [b for _, b in pairs]


def _leave_out(data: Data, held: Sequence[int], label: str) -> Fold:
    rest = [i for i in range(data.n_tests) if i not in held]
    train, test = data.subset(rest), data.subset(held)
    firsts, seconds = _time_halves([data.prepared[i] for i in held])
    halves = None
    if len(firsts) == len(held):
        base, rate = data.prob.base, data.full_rate_hz
        halves = Fold(
            f"{label}, its second halves predicted from its first",
            Data.build(base, [*train.prepared, *firsts], rate),
            Data.build(base, seconds, rate),
        )
    return Fold(label, train, test, halves)


def folds(data: Data, max_click_folds: int = 2) -> list[Fold]:
    """Leave one frequency out; leave one click out where there are three or more; a
    single test (or one setting) is split into its first and second halves in time."""
    metas = [p.data.meta for p in data.prepared]
    freqs = sorted({round(m.frequency_hz, 3) for m in metas})
    clicks = sorted({(m.clicks, m.gas_clicks, m.setting) for m in metas})  # every adjuster's
    out: list[Fold] = []
    if len(freqs) >= 2:
        for f in freqs:
            held = [i for i, m in enumerate(metas) if round(m.frequency_hz, 3) == f]
            out.append(_leave_out(data, held, f"{f:g} Hz left out"))
    if len(clicks) >= 3:
        pick = [clicks[0], clicks[-1], clicks[len(clicks) // 2]][:max_click_folds]
        for c in dict.fromkeys(pick):
            held = [i for i, m in enumerate(metas) if (m.clicks, m.gas_clicks, m.setting) == c]
            named = ", ".join(f"{n} {v}" for n, v in c[2]) or f"{c[0]} clicks"
            out.append(_leave_out(data, held, f"{named} left out"))
    if not out:
        firsts, seconds = _time_halves(data.prepared)
        if firsts:
            a = Data.build(data.prob.base, firsts, data.full_rate_hz)
            b = Data.build(data.prob.base, seconds, data.full_rate_hz)
            out += [Fold("second half predicted", a, b), Fold("first half predicted", b, a)]
    return out


@dataclass
class FoldBaseline:
    """A fold and the baseline's held-out structure in it, per held-out test; that of its
    halves split (Fold.halves) worked out the first time a candidate needs it."""

    fold: Fold
    structure: FloatArray
    base: Fitted
    max_nfev: int
    _halves: FloatArray | None = None

    def halves_structure(self) -> FloatArray:
        if self._halves is None:
            assert self.fold.halves is not None
            self._halves = _baseline_structure(self.fold.halves, self.base, self.max_nfev)
        return self._halves


def _baseline_structure(fold: Fold, base: Fitted, max_nfev: int) -> FloatArray:
    b_train = train_fold(fold.train, base, max_nfev, warm=WARM_FOLDS)
    return _structure(fold.test, predict(fold.test, b_train, base).residual)


def _fold_structure(shared: tuple[Fitted, int], fold: Fold) -> FloatArray:
    return _baseline_structure(fold, *shared)


def baseline_folds(
    fold_list: Sequence[Fold], base: Fitted, max_nfev: int, workers: Workers = SERIAL
) -> list[FoldBaseline]:
    """The baseline's held-out structure in each fold, per held-out test."""
    found = workers.map(_fold_structure, (base, max_nfev), fold_list)
    return [FoldBaseline(f, b, base, max_nfev) for f, b in zip(fold_list, found, strict=True)]


def _acts_on(data: Data, cand: Candidate, share: float = 0.01) -> bool:
    """Whether the candidate's own force component reaches `share` of its peak effect on
    these tests (so they can place its parameters)."""
    model = cand.fitted.model
    if model.term(cand.name) is None or cand.effect_peak_n <= 0:
        return True
    own = own_force(data, cand.fitted, cand.name)
    if own is None:
        return True
    return float(np.max(np.abs(own), initial=0.0)) >= share * cand.effect_peak_n


def _acting_tests(test: Data, predicted: Fitted, cand: Candidate) -> NDArray[np.bool_]:
    """Which held-out tests the candidate's own force, as trained, reaches (ACTS_SHARE of
    its largest phase mean on the search's tests)."""
    own = own_force(test, predicted, cand.name)
    if own is None:
        return np.ones(test.n_tests, dtype=bool)
    peak = cand.own_peak_n if math.isfinite(cand.own_peak_n) else cand.effect_peak_n
    binned = np.abs(test.bin_matrix(own[:, None])[:, 0]).reshape(test.n_tests, -1)
    return np.asarray(np.max(binned, axis=1) >= ACTS_SHARE * peak)


def judged_structure(
    base: FloatArray, cand: FloatArray, acts: NDArray[np.bool_]
) -> tuple[float, float]:
    """One fold's structure before and after the term, per held-out test → the totals it
    is judged on: the structure of the tests it acts on, plus what it removes elsewhere;
    and that less the change over every test. Harm where the term's own force is small (a
    shifted gas spring, say) still counts against it; the gain 1 - after/before stays ≤ 1."""
    b, c = np.maximum(base, 0.0), np.maximum(cand, 0.0)
    before = float(np.sum(b[acts]) + np.sum(np.maximum(b - c, 0.0)[~acts]))
    return before, before - float(np.sum(b) - np.sum(c))


@dataclass(frozen=True)
class FoldOutcome:
    """A candidate trained on one fold's tests and predicting the ones it leaves out."""

    label: str
    skipped: bool  # the term acts on neither the training tests nor their first halves
    halves: bool  # judged on the fold's halves split (Fold.halves)
    acts: NDArray[np.bool_]  # the judged tests the term's own force, as trained, reaches
    reaches: bool
    structure: FloatArray  # per judged test, with the term


def fold_outcome(fold: Fold, cand: Candidate, max_nfev: int) -> FoldOutcome:
    """The candidate refitted on the fold's training tests, its prediction of the rest."""
    label = fold.label
    halves = False
    if not _acts_on(fold.train, cand):
        # A threshold reached only on the held-out tests (cavitation on the stiffest
        # click): training cannot place it. Trained on the first halves of those
        # tests as well, it is judged on their second halves; where it acts on
        # neither, this fold says nothing either way.
        if fold.halves is None or not _acts_on(fold.halves.train, cand):
            none = np.zeros(0, dtype=bool)
            return FoldOutcome(label, True, False, none, False, np.zeros(0))
        fold, halves = fold.halves, True
    c_train = train_fold(fold.train, cand.fitted, max_nfev, warm=WARM_FOLDS)
    predicted = predict(fold.test, c_train, cand.fitted)
    acts = _acting_tests(fold.test, predicted, cand)
    reaches = bool(np.any(acts))
    if not reaches:
        # Its own force is absent here, but with it the shared parameters are placed
        # without its distortion: that gain is judged on all the held-out tests.
        acts = np.ones_like(acts)
    return FoldOutcome(
        fold.label, False, halves, acts, reaches, _structure(fold.test, predicted.residual)
    )


def judge(
    outcomes: Sequence[FoldOutcome],
    whole: Sequence[FloatArray],
    halves: Sequence[FloatArray | None],
) -> tuple[float, str]:
    """Share of the held-out structure on the tests the term acts on that it removes
    (change summed over every held-out test), in the median fold (1: all of it, 0: none,
    < 0: the term makes held-out prediction worse), and the folds in words. `whole` and
    `halves`: the baseline's structure per fold (on its halves split, where judged so).

    The median, not the folds pooled: a fold's short refit can extrapolate wildly to the
    tests it leaves out, and pooled, that one fold decides. On a held-out-plant sweep
    with 0.86 % air, a thermal term trained without the stiffest click predicted it 630 N
    RMS off; the air, judged beside it, took every other fold from 28-81 N to 2.5-5.6 N
    and was dropped at a pooled gain of -11. Only folds whose left-out tests the term's
    own force reaches vote (all, where it reaches none): vapour on the stiffest click says
    nothing in a fold that leaves out only tests without it."""
    gains: list[float] = []  # folds whose left-out tests the term's own force reaches
    elsewhere: list[float] = []
    parts = []
    for o, b_whole, b_halves in zip(outcomes, whole, halves, strict=True):
        if o.skipped:
            parts.append(f"{o.label}: skipped, the term does not act on the rest")
            continue
        b = b_halves if o.halves else b_whole
        assert b is not None
        sb, sc = judged_structure(b, o.structure, o.acts)
        if sb > 0:
            (gains if o.reaches else elsewhere).append(1.0 - sc / sb)
        n = int(np.count_nonzero(o.acts)) * N_BINS
        shown = f"{math.sqrt(sb / n):.3g} → {math.sqrt(max(sc, 0.0) / n):.3g} N"
        where = "" if np.all(o.acts) else f" (on the {int(np.count_nonzero(o.acts))} it acts on)"
        parts.append(f"{o.label}: {shown}{where}")
    return median_gain(gains, elsewhere), "; ".join(parts)


def heldout_gain(
    baselines: Sequence[FoldBaseline], cand: Candidate, max_nfev: int
) -> tuple[float, str]:
    """The candidate's held-out gain and its folds in words (`judge`), fold by fold here."""
    outcomes = [fold_outcome(fb.fold, cand, max_nfev) for fb in baselines]
    halves = [
        fb.halves_structure() if o.halves else None
        for fb, o in zip(baselines, outcomes, strict=True)
    ]
    return judge(outcomes, [fb.structure for fb in baselines], halves)


def _fold_task(
    shared: tuple[Fitted, int], item: tuple[Fold, Candidate | None]
) -> FloatArray | FoldOutcome:
    """A baseline's held-out structure on a fold (no candidate), or a candidate's outcome."""
    base, max_nfev = shared
    fold, cand = item
    if cand is None:
        return _baseline_structure(fold, base, max_nfev)
    return fold_outcome(fold, cand, max_nfev)


class HeldOut:
    """The held-out scores of a round's candidates beside `base`, asked for in batches
    (the search scores a candidate only when its gain could decide something: search.py's
    `Search.round`). The baseline's structure on each fold (and on each halves split some
    candidate is judged on) is refitted once, the first time it is needed, and shared by
    every batch after: a candidate's score is the same whether it is asked for alone or
    with others (each refit is a pure function of its fold and its start). So candidates
    a later batch will likely ask for can be refitted in an earlier one's map
    (`prefetch`): one map, not two one after the other, each ending with a worker idle
    while the other finishes its last fold."""

    def __init__(
        self, fold_list: Sequence[Fold], base: Fitted, max_nfev: int, workers: Workers = SERIAL
    ) -> None:
        self.fold_list = list(fold_list)
        self.base = base
        self.max_nfev = max_nfev
        self.workers = workers
        self._whole: list[FloatArray] | None = None
        self._halves: list[FloatArray | None] = [None] * len(self.fold_list)
        self._outcomes: dict[str, list[FoldOutcome]] = {}  # by candidate, refitted already

    def prefetch(self, cands: Sequence[Candidate]) -> None:
        """Every (candidate, fold) refit of `cands` not made yet, and the baseline's on
        each fold the first time, items of one map (as many items as folds times
        candidates, so the workers stay busy where one candidate's folds one after
        another kept a worker waiting). Their scores are not taken: `gains` does."""
        todo = list({c.name: c for c in cands if c.name not in self._outcomes}.values())
        if not todo:
            return
        nf = len(self.fold_list)
        items: list[tuple[Fold, Candidate | None]] = []
        if self._whole is None:
            items += [(f, None) for f in self.fold_list]
        items += [(f, c) for c in todo for f in self.fold_list]
        got = self.workers.map(_fold_task, (self.base, self.max_nfev), items)
        if self._whole is None:
            self._whole = [cast(FloatArray, g) for g in got[:nf]]
            got = got[nf:]
        for i, c in enumerate(todo):
            self._outcomes[c.name] = cast(list[FoldOutcome], got[i * nf : (i + 1) * nf])

    def gains(self, cands: Sequence[Candidate]) -> list[tuple[float, str]]:
        """`heldout_gain` of each of `cands`: their refits (`prefetch`), then the baseline
        on each halves split one of them is judged on and no earlier batch needed."""
        if not cands:
            return []
        self.prefetch(cands)
        assert self._whole is not None
        outcomes = [self._outcomes[c.name] for c in cands]
        need = [
            i
            for i in range(len(self.fold_list))
            if self._halves[i] is None and any(o[i].halves for o in outcomes)
        ]
        split = self.workers.map(
            _fold_task,
            (self.base, self.max_nfev),
            [(cast(Fold, self.fold_list[i].halves), None) for i in need],
        )
        for i, h in zip(need, split, strict=True):
            self._halves[i] = cast(FloatArray, h)
        return [judge(o, self._whole, self._halves) for o in outcomes]


def heldout_gains(
    fold_list: Sequence[Fold],
    base: Fitted,
    cands: Sequence[Candidate],
    max_nfev: int,
    workers: Workers = SERIAL,
) -> list[tuple[float, str]]:
    """`heldout_gain` of each candidate beside `base` (HeldOut, all in one batch)."""
    return HeldOut(fold_list, base, max_nfev, workers).gains(cands)


def median_gain(reaching: Sequence[float], elsewhere: Sequence[float]) -> float:
    """The median of the folds' gains, of those whose left-out tests the term reaches
    (of the others where there are none; 0 without any fold to judge)."""
    judged = list(reaching) or list(elsewhere)
    return float(np.median(judged)) if judged else 0.0
