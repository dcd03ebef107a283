"""Bleed areas per click with the globals and terms held: eq. 8 searches, uncertainty,
Talbott's single area, bleed shares and identifiability (the fit's steps 1, 3-6)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from shockdyno.fit.line_search import area_grid, golden_search, grid_search
from shockdyno.fit.problem import StackedProblem
from shockdyno.model import evaluate
from shockdyno.model.composite import DamperModel

FloatArray = NDArray[np.float64]

# Identifiable: the area is pinned to within this relative 1-σ uncertainty, clear of zero,
# and the bleed passes at least this share of the flow (else the valve or the leak
# carry it and the data say little about the bleed).
MAX_RELATIVE_SD = 0.05
MIN_BLEED_SHARE = 0.02
MIN_COVERAGE = 0.1


def start_areas(
    prob: StackedProblem, model: DamperModel, a_max: float
) -> tuple[FloatArray, FloatArray]:
    """Each click's A_bc and A_bt minimising squared error, globals held at the spec's."""
    n = prob.n_groups

    def sse(values: FloatArray) -> FloatArray:
        r = prob.force(model, values[:n], values[n:]) - prob.f
        return prob.per_problem(r * r)

    lo, hi = grid_search(sse, 2 * n, area_grid(a_max))
    best, _ = golden_search(sse, lo, hi, iterations=25)
    return best[:n], best[n:]


# Held-out clicks' areas: each direction scanned over this factor range about the best
# start, then narrowed by golden section, in turn (compression, rebound, compression).
HELD_SCAN = np.geomspace(0.8, 1.25, 13)
HELD_GOLDEN_STEPS = 10


def held_out_areas(
    prob: StackedProblem,
    model: DamperModel,
    a_max: float,
    hint: tuple[FloatArray, FloatArray] | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Each click's A_bc and A_bt minimising its squared error with the globals and terms
    held, on tests the terms were not fitted to (a fold's left-out clicks).

    `start_areas` treats a click's compression and rebound samples as two problems, each
    seeing its own area; a chamber term couples them (vapour formed in rebound collapses
    in compression), and under strong vapour the error over a stiff click's A_bc is a
    narrow valley beside a cliff (where the vapour's collapse crosses the samples): a
    descent stops on whichever side it began, so a held-out score turned on the last bits
    of its inputs (benchmarks/results/held-out-areas-2026-12-01.txt). So each click keeps
    the better of that start and `hint` (the full fit's areas, per click; NaN where it has
    none), then each direction in turn is scanned over ±22 % and narrowed (about 80 model
    calls, for every click at once: the clicks' samples are disjoint)."""

    def sse(bc: FloatArray, bt: FloatArray) -> FloatArray:
        r = prob.force(model, bc, bt) - prob.f
        return prob.per_group(r * r)

    bc, bt = start_areas(prob, model, a_max)
    best = sse(bc, bt)
    if hint is not None:
        ok = np.isfinite(hint[0]) & np.isfinite(hint[1])
        if np.any(ok):
            hbc, hbt = np.where(ok, hint[0], bc), np.where(ok, hint[1], bt)
            got = sse(hbc, hbt)
            take = ok & (got < best)
            bc, bt = np.where(take, hbc, bc), np.where(take, hbt, bt)
            best = np.where(take, got, best)
    bc, best = _scan_one(lambda v: sse(v, bt), bc, best, a_max)
    bt, best = _scan_one(lambda v: sse(bc, v), bt, best, a_max)
    bc, best = _scan_one(lambda v: sse(v, bt), bc, best, a_max)
    return bc, bt


def _scan_one(
    along: Callable[[FloatArray], FloatArray], cur: FloatArray, best: FloatArray, a_max: float
) -> tuple[FloatArray, FloatArray]:
    """One direction's areas (`along`: the error per click at these areas, the other
    direction's held): scanned over HELD_SCAN about `cur`, narrowed about the best point,
    kept per click where better than `best`."""
    n = cur.size
    trials = np.stack([np.clip(cur * k, 0.0, a_max) for k in HELD_SCAN])
    scores = np.stack([along(t) for t in trials])
    i = np.argmin(scores, axis=0)
    cols = np.arange(n)
    lo = trials[np.maximum(i - 1, 0), cols]
    hi = trials[np.minimum(i + 1, HELD_SCAN.size - 1), cols]
    x, fx = golden_search(along, lo, hi, HELD_GOLDEN_STEPS)
    scanned = scores[i, cols]
    x, fx = np.where(fx <= scanned, x, trials[i, cols]), np.minimum(fx, scanned)
    take = fx < best
    return np.where(take, x, cur), np.where(take, fx, best)


def l1_problems(prob: StackedProblem, model: DamperModel) -> Callable[[FloatArray], FloatArray]:
    """Eq. 8 per (click, direction) problem for candidate areas [A_bc..., A_bt...]."""
    n = prob.n_groups

    def fun(values: FloatArray) -> FloatArray:
        return prob.per_problem(np.abs(prob.force(model, values[:n], values[n:]) - prob.f))

    return fun


def polish_l1(
    prob: StackedProblem, model: DamperModel, a0: FloatArray, sd: FloatArray, a_max: float
) -> tuple[FloatArray, FloatArray]:
    """Eq. 8 minimised per click and direction, near the least-squares areas.

    Where the data are not what the model can produce (outliers, unmodelled physics) the
    eq. 8 optimum may lie far from the least-squares one, so a search over the whole
    range runs too and each problem keeps the better of the two.
    """
    fun = l1_problems(prob, model)
    sd = np.nan_to_num(sd, nan=0.0, posinf=0.0)
    width = np.maximum.reduce([10 * sd, 0.1 * a0, np.full(a0.shape, 1e-10)])
    near, f_near = golden_search(
        fun, np.clip(a0 - width, 0.0, a_max), np.clip(a0 + width, 0.0, a_max), 30
    )
    lo, hi = grid_search(fun, a0.size, area_grid(a_max))
    wide, f_wide = golden_search(fun, lo, hi, 30)
    better = f_wide < f_near
    return np.where(better, wide, near), np.where(better, f_wide, f_near)


def between_test_sd(
    prob: StackedProblem, model: DamperModel, areas: FloatArray, a_max: float
) -> FloatArray:
    """Standard error of each click's area from the scatter of per-test estimates.

    Each test (frequency) of a click is fitted on its own, by eq. 8 with the globals
    fixed; the scatter of those estimates shows what the sample-noise covariance cannot:
    systematic misfit that differs between frequencies (model error, temperature drift,
    velocity estimation). NaN where a click has fewer than two tests.
    """
    n, nt = prob.n_groups, int(prob.test_id.max()) + 1
    tid = prob.test_id
    pid = np.where(prob.comp, tid, np.where(prob.v < 0, tid + nt, 2 * nt))
    test_group = np.zeros(nt, dtype=np.intp)
    test_group[tid] = prob.group
    start = np.concatenate([areas[:n][test_group], areas[n:][test_group]])

    def fun(values: FloatArray) -> FloatArray:
        r = np.abs(prob.force(model, values[:nt][tid], values[nt:][tid]) - prob.f)
        return np.bincount(pid, weights=r, minlength=2 * nt + 1)[: 2 * nt].astype(float)

    # A test that barely moves one way says nothing about that direction's area.
    enough = np.bincount(pid, minlength=2 * nt + 1)[: 2 * nt] >= 10

    width = np.maximum(0.5 * start, 1e-10)
    est, _ = golden_search(
        fun, np.clip(start - width, 0, a_max), np.clip(start + width, 0, a_max), 30
    )
    out = np.full(2 * n, np.nan)
    for g in range(n):
        for d in range(2):
            mine = (test_group == g) & enough[d * nt : (d + 1) * nt]
            vals = est[d * nt : (d + 1) * nt][mine]
            if vals.size >= 2:
                out[d * n + g] = float(np.std(vals, ddof=1) / math.sqrt(vals.size))
    return out


def ga_fitness(
    prob: StackedProblem, model: DamperModel, a_max: float
) -> Callable[[FloatArray], FloatArray]:
    """Eq. 8 per click for GA individuals u in [0, 1]², area = a_max u².

    u has shape (individuals, clicks, 2); all individuals are scored in one model call
    (the tests tiled, each copy its own segments, so stateful terms stay per test).
    """
    n, m = prob.n_groups, prob.size
    # A model with fast lags runs on every sample; the objective takes its own samples.
    base = prob.full_inputs if prob.full_rate else prob.inputs
    pick = prob.obj_in_full if prob.full_rate else np.arange(m)
    g = prob.full_group if prob.full_rate else prob.group
    mb = base.size
    # Calls of ~20-40 k samples run fastest (per-call overhead vs cache misses).
    chunk = max(1, 30_000 // max(mb, 1))
    tiled = {k: base.tile(k) for k in {chunk, 1}}

    def fitness(u: FloatArray) -> FloatArray:
        out = np.empty((u.shape[0], n))
        for lo in range(0, u.shape[0], chunk):
            part = u[lo : lo + chunk]
            k = part.shape[0]
            a = a_max * part * part
            bc = a[:, g, 0].ravel()
            bt = a[:, g, 1].ravel()
            inputs = tiled[k] if k in tiled else base.tile(k)
            prob.count(k * mb)
            force = model.force(inputs, bc, bt).reshape(k, mb)[:, pick].ravel()
            r = np.abs(force - np.tile(prob.f, k))
            rows = np.repeat(np.arange(k), m) * n + np.tile(prob.group, k)
            out[lo : lo + k] = np.bincount(rows, weights=r, minlength=k * n).reshape(k, n)
        return out

    return fitness


def talbott_areas(
    prob: StackedProblem, model: DamperModel, a_max: float, tau: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """One A_b per click minimising eq. 8: (A_b, its 1-σ uncertainty, eq. 8 there)."""

    def fun(values: FloatArray) -> FloatArray:
        return prob.per_group(np.abs(prob.force(model, values, values) - prob.f))

    lo, hi = grid_search(fun, prob.n_groups, area_grid(a_max))
    a_b, obj = golden_search(fun, lo, hi, iterations=35)
    r0 = prob.force(model, a_b, a_b) - prob.f
    h = np.maximum(1e-6 * a_b, 1e-13)
    dr = (prob.force(model, a_b + h, a_b + h) - prob.f - r0) / h[prob.group]
    m = np.bincount(prob.group, minlength=prob.n_groups)
    s2 = prob.per_group(r0 * r0) / np.maximum(m - 1, 1)
    info = prob.per_group(dr * dr)
    with np.errstate(divide="ignore"):
        sd = np.where(info > 0, np.sqrt(tau * s2 / info), np.inf)
    return a_b, sd, obj


def bleed_shares(
    prob: StackedProblem, model: DamperModel, a_bc: FloatArray, a_bt: FloatArray
) -> FloatArray:
    """Flow-weighted share of the bleed, per (click, direction) problem (paper's physics)."""
    x, v, a = model.motion(prob.inputs)
    bd = evaluate(model.spec, x, v, a, a_bc[prob.group], a_bt[prob.group])
    prob.count(prob.size)
    w = np.abs(prob.v)
    with np.errstate(invalid="ignore", divide="ignore"):
        return prob.per_problem(bd.bleed_share * w) / prob.per_problem(w)


def identifiable(a: float, sd: float, share: float, a_max: float, coverage: float) -> bool:
    """See MAX_RELATIVE_SD; also: off the bound of the bore (where the covariance means
    nothing), and the direction holds at least MIN_COVERAGE of the click's samples (a test
    that barely moves one way gives only near-reversal samples for that direction)."""
    return bool(
        np.isfinite(sd)
        and a > 3 * sd
        and sd <= MAX_RELATIVE_SD * a
        and a < 0.95 * a_max
        and coverage >= MIN_COVERAGE
        and np.isfinite(share)
        and share >= MIN_BLEED_SHARE
    )
