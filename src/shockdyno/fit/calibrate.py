"""Joint least squares over the damper's globals, the terms' free parameters and every
click's bleed areas (the fit's step 2, docs/fit-method.md).

Unknowns, scaled to order 1: the spec globals / their scale, each term parameter / its
declared scale, and the areas in mm². The Jacobian is built by finite differences in
(globals + term parameters + 2) model evaluations whatever the number of clicks: one
column per global or term parameter, and all areas in one go, since they touch disjoint
samples. Its covariance, inflated for correlated residuals, gives each uncertainty.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shockdyno.fit.parameters import (
    AREA_BC,
    AREA_BT,
    GLOBAL,
    TERM,
    Parameter,
    ParameterSet,
    calibration_set,
)
from shockdyno.fit.problem import StackedProblem
from shockdyno.model.chamber import linearised
from shockdyno.model.composite import DamperModel
from shockdyno.model.params import Param

FloatArray = NDArray[np.float64]
AREA_SCALE = 1e-6  # m²: areas are optimised in mm²
CHECK_SOLVER_JACOBIAN = False  # tests: the solver's final Jacobian is jacobian(p) bit for bit


@dataclass(frozen=True)
class Calibration:
    overrides: dict[str, float]  # spec globals
    globals_sd: dict[str, float]
    term_values: dict[str, float]  # qualified term parameters, fitted
    term_sd: dict[str, float]
    a_bc: FloatArray
    a_bt: FloatArray
    sd_bc: FloatArray
    sd_bt: FloatArray
    tau: float  # variance inflation for correlated residuals
    nfev: int
    cost_rms_n: float
    # The Jacobian at the end (rows: the residual's, samples then penalty; columns: the
    # parameter vector, globals, terms, A_bc per group, A_bt per group), per unit of each
    # parameter's scale, and those scales.
    jac: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    scales: FloatArray = field(default_factory=lambda: np.zeros(0))

    def model(self, prob: StackedProblem, base: DamperModel) -> DamperModel:
        return DamperModel(prob.spec_with(self.overrides), base.terms, base.values).with_values(
            self.term_values
        )


def autocorrelation_factor(r: FloatArray, test_id: NDArray[np.intp], max_lag: int = 40) -> float:
    """1 + 2 Σ ρ_k of the residuals (within tests), summed while ρ_k stays above 0.05.

    Least-squares covariance assumes independent residuals; correlated ones (model error,
    differentiation of a noisy x) carry fewer independent pieces of information, and the
    variance is scaled up by this factor, as for the mean of a correlated series.
    """
    denom = float(np.sum(r * r))
    if denom <= 0:
        return 1.0
    tau = 1.0
    for k in range(1, max_lag + 1):
        same_k = test_id[k:] == test_id[:-k]
        rho = float(np.sum(r[k:] * r[:-k] * same_k)) / denom
        if rho < 0.05:
            break
        tau += 2 * rho
    return tau


def calibrate(
    prob: StackedProblem,
    base: DamperModel,
    params: Sequence[Parameter],
    free: Sequence[str],
    a_bc0: FloatArray,
    a_bt0: FloatArray,
    a_max: float,
    max_nfev: int = 60,
    robust: bool = True,
    jac0: FloatArray | None = None,
    term_limits: Mapping[str, tuple[float, float]] | None = None,
) -> Calibration:
    """Least squares (then soft-L1) over globals, free term parameters and all areas.

    `term_limits`: ranges (in each parameter's own unit) some free term parameters are
    held within, narrower than their declared ones (the two intersected; the limit alone
    where they do not meet): a term's factor on a spec value moved beyond a spec's error
    (diagnose/tolerance.py).
    `jac0`: the Jacobian at the start, known already (a refit on part of the tests from a
    fit on all of them has its rows), per unit of each parameter (not of its scale): the
    solve starts with it and updates it by Broyden's rank-one rule at each point it
    accepts instead of differencing the model again there (a quasi-Newton least squares;
    its final σ are the updated Jacobian's). Without the robust loss only."""
    assert jac0 is None or not robust
    declared: dict[str, Param] = dict(base.param_list())
    held = term_limits or {}
    ps = calibration_set(
        [replace(g, value=prob.base.value(g.name)) for g in params],  # from the problem's spec
        {
            q: (base.value(q), declared[q].scale,
                *_range(declared[q], held.get(q)))
            for q in free
        },
        a_bc0,
        a_bt0,
        AREA_SCALE,
        a_max,
    )  # fmt: skip
    lb, ub = ps.bounds()
    scales = np.array([q.scale for q in ps.items], dtype=float)
    p0 = np.clip(ps.theta0(), lb, np.where(ub > lb, ub - 1e-12 * np.maximum(np.abs(ub), 1), ub))
    res = _Residuals(prob, base, ps, ub, history=base.carries_state(free))
    jac = res.jacobian if jac0 is None else _Broyden(res.residual, jac0 * scales).jacobian
    p, r_all, jac_end, nfev = _solve(res, jac, p0, (lb, ub), max_nfev, robust, jac0 is None)
    return _calibration(prob, ps, p, r_all, jac_end, nfev, scales)


def _range(p: Param, limit: tuple[float, float] | None) -> tuple[float, float]:
    """A term parameter's range in units of its scale: the declared one, narrowed to
    `limit` (its own unit); the limit alone where the two do not meet."""
    lo, hi = p.lo, p.hi
    if limit is not None:
        lo, hi = max(lo, limit[0]), min(hi, limit[1])
        if lo >= hi:
            lo, hi = limit
    return lo / p.scale, hi / p.scale


class _Residuals:
    """The calibration's residual (samples, then the terms' penalties) at a parameter
    vector, the last one kept, and its Jacobian by finite differences."""

    def __init__(
        self,
        prob: StackedProblem,
        base: DamperModel,
        ps: ParameterSet,
        ub: FloatArray,
        history: bool,  # not a channel delay alone: see _area_columns
    ) -> None:
        self.prob, self.base, self.ps, self.ub, self.history = prob, base, ps, ub, history
        self.shared = ps.span(GLOBAL, TERM)  # one Jacobian column each
        self.bc_at, self.bt_at = ps.span(AREA_BC), ps.span(AREA_BT)  # all in one evaluation
        self.in_group = [prob.group == g for g in range(prob.n_groups)]
        self.penalty_weight = math.sqrt(prob.size)
        self.cache: dict[bytes, FloatArray] = {}

    def model_at(self, p: FloatArray) -> DamperModel:
        ps = self.ps
        return self.base.with_spec(self.prob.spec_with(ps.values(p, GLOBAL))).with_values(
            ps.values(p, TERM)
        )

    def evaluated(self, p: FloatArray) -> FloatArray:
        model = self.model_at(p)
        prob, ps = self.prob, self.ps
        r = prob.force(model, ps.vector(p, AREA_BC), ps.vector(p, AREA_BT)) - prob.f
        pen = model.penalty()
        return np.concatenate([r, self.penalty_weight * pen]) if pen.size else r

    def residual(self, p: FloatArray) -> FloatArray:
        key = p.tobytes()
        if key not in self.cache:
            self.cache.clear()
            self.cache[key] = self.evaluated(p)
        return self.cache[key]

    def jacobian(self, p: FloatArray) -> FloatArray:
        # A chamber's columns are one Newton step a chamber step from its trajectory at p
        # (model/chamber.linearised: 1 balance a step where a solve takes 2.3), within the
        # columns' own finite-difference error. So p is evaluated first, in the block.
        with linearised() as guides:
            base = self.evaluated(p)  # solved in full: the guide of every column
            if guides:
                # The columns' base is p's own guided evaluation, not the solve: a
                # parameter nothing depends on (a release pressure never reached) then
                # has a column of exact zeros, not the solve's leftover over h, which
                # was a gradient that walked it into the data and a σ from noise.
                base = self.evaluated(p)
            return self.differenced(p, base)

    def differenced(self, p: FloatArray, r0: FloatArray) -> FloatArray:
        jac = np.zeros((r0.size, p.size))
        h = 1e-6 * np.maximum(np.abs(p), 0.1)
        h = np.where(p + h > self.ub, -h, h)
        for j in range(self.shared.start, self.shared.stop):
            q = p.copy()
            q[j] += h[j]
            jac[:, j] = (self.evaluated(q) - r0) / h[j]
        self._area_columns(jac, p, h, r0)
        return jac

    def _area_columns(self, jac: FloatArray, p: FloatArray, h: FloatArray, r0: FloatArray) -> None:
        bc_at, bt_at, n = self.bc_at, self.bt_at, self.prob.n_groups
        if self.history:
            # A state carries each area's effect past reversal (a chamber's pressure, a
            # lag): a compression sample depends on the rebound area too. Each group's
            # samples depend on its own areas only, so one step of every group's
            # compression areas, then one of the rebound areas, gives exact columns. The
            # split below, on a 0.3 % air sim-rig sweep, stopped the fit where no step
            # descended: 0.39 % air, a leak on the closed click, 20x the squared error
            # of the fit that reached 0.299 % (tests/diagnose/test_area_columns.py).
            # A channel delay alone carries none: the split by the delayed motion's
            # direction is exact, and one evaluation cheaper per Jacobian.
            for at in (bc_at, bt_at):
                q = p.copy()
                q[at] += h[at]
                dr = self.evaluated(q) - r0
                for g in range(n):
                    rows = np.flatnonzero(self.in_group[g])  # the penalty rows stay 0
                    jac[rows, at.start + g] = dr[rows] / h[at.start + g]
            return
        m = self.prob.size
        q = p.copy()
        q[bc_at.start :] += h[bc_at.start :]
        dr = self.evaluated(q) - r0
        _, v, _ = self.model_at(p).motion(self.prob.inputs)  # the split the areas follow
        comp, reb = v > 0, v < 0
        for g in range(n):
            rows_bc = np.flatnonzero(self.in_group[g] & comp)
            rows_bt = np.flatnonzero(self.in_group[g] & reb)
            jac[rows_bc, bc_at.start + g] = dr[:m][rows_bc] / h[bc_at.start + g]
            jac[rows_bt, bt_at.start + g] = dr[:m][rows_bt] / h[bt_at.start + g]


class _Broyden:
    """A Jacobian without differencing: `start` (per unit of each parameter's scale) at
    the first point; after, the last one with Broyden's update for the step to p:
    J + (Δr - J s) sᵀ / sᵀs, which maps the step onto the change it made."""

    def __init__(self, residual: Callable[[FloatArray], FloatArray], start: FloatArray) -> None:
        self.residual, self.start = residual, start
        self.last: dict[str, FloatArray] = {}

    def jacobian(self, p: FloatArray) -> FloatArray:
        r = self.residual(p)
        quasi = self.last
        if not quasi:
            assert self.start.shape == (r.size, p.size)
            jac = np.asarray(self.start, dtype=float)
        else:
            step = p - quasi["p"]
            jac = quasi["jac"]
            ss = float(step @ step)
            if ss > 0:
                jac = jac + np.outer(r - quasi["r"] - jac @ step, step / ss)
        quasi.update(p=p.copy(), r=r.copy(), jac=jac)
        return jac


def _solve(
    res: _Residuals,
    jac: Callable[[FloatArray], FloatArray],
    p0: FloatArray,
    bounds: tuple[FloatArray, FloatArray],
    max_nfev: int,
    robust: bool,
    differenced: bool,
) -> tuple[FloatArray, FloatArray, FloatArray, int]:
    """trf from p0 (then soft-L1 from its end, if robust): the end point, the residual
    and Jacobian there, and the model evaluations the solver asked for."""
    from scipy.optimize import least_squares  # here: a quarter of a second to import

    common: dict[str, Any] = {  # Any: least_squares' options, each of its own type
        "jac": jac,
        "bounds": bounds,
        "method": "trf",
        "x_scale": "jac",
        "ftol": 1e-10,
        "xtol": 1e-10,
        "gtol": 1e-10,
        "max_nfev": max_nfev,
    }
    residual, size = res.residual, res.prob.size
    sol = least_squares(residual, p0, **common)
    nfev = int(sol.nfev)
    if robust:
        r = residual(sol.x)[:size]
        scale = 3 * 1.4826 * float(np.median(np.abs(r - np.median(r))))
        sol = least_squares(residual, sol.x, loss="soft_l1", f_scale=max(scale, 1e-3), **common)
        nfev += int(sol.nfev)
    p = sol.x
    if robust:
        return p, residual(p), res.jacobian(p), nfev  # the soft-L1 solve's are its scaled ones
    # The solver's own residual and Jacobian at its end: trf evaluates both at every
    # point it accepts, so these are residual(p) and jacobian(p) as computed there
    # (a second Jacobian here was one of every nine model evaluations of a diagnosis).
    r_all, jac_end = np.asarray(sol.fun), np.asarray(sol.jac)
    if CHECK_SOLVER_JACOBIAN and differenced:
        assert np.array_equal(jac_end, res.jacobian(p)) and np.array_equal(r_all, residual(p))
    return p, r_all, jac_end, nfev


def _calibration(
    prob: StackedProblem,
    ps: ParameterSet,
    p: FloatArray,
    r_all: FloatArray,
    jac: FloatArray,
    nfev: int,
    scales: FloatArray,
) -> Calibration:
    """The values at p and their σ: the covariance from the Jacobian, scaled by the
    residual's variance and inflated for its correlation."""
    r = r_all[: prob.size]
    dof = max(r.size - p.size, 1)
    tau = autocorrelation_factor(r, prob.test_id)
    s2 = float(np.sum(r * r)) / dof
    cov = np.linalg.pinv(jac.T @ jac) * s2 * tau
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    sd[~np.any(jac != 0, axis=0)] = np.inf  # no sample depends on it: not measured at all
    return Calibration(
        overrides=ps.values(p, GLOBAL),
        globals_sd=ps.values(sd, GLOBAL),
        term_values=ps.values(p, TERM),
        term_sd=ps.values(sd, TERM),
        a_bc=ps.vector(p, AREA_BC),
        a_bt=ps.vector(p, AREA_BT),
        sd_bc=ps.vector(sd, AREA_BC),
        sd_bt=ps.vector(sd, AREA_BT),
        tau=tau,
        nfev=nfev,
        cost_rms_n=math.sqrt(float(np.mean(r * r))),
        jac=jac,
        scales=scales,
    )
