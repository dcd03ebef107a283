"""Fit a sweep: calibrate the damper's globals, then the bleed areas per click (eq. 8).

Steps (docs/fit.md has the why of each):

1. Start: with the nominal globals, each click's A_bc and A_bt by a log grid and a
   golden-section search (compression samples depend on A_bc only, rebound on A_bt only).
2. Calibrate: one least-squares problem over every test, unknowns the globals (gas
   pressure, friction, each valve's preload and face area), the force channel's delay
   and every click's A_bc, A_bt; plain, then with a soft-L1 loss. The Jacobian is built
   by finite differences in 8 model evaluations whatever the number of clicks: the
   globals and the delay one column each, and all areas in one go, since they touch
   disjoint samples. Its covariance gives each parameter's uncertainty.
3. Per click, with the globals fixed, eq. 8 (sum of |F_model - F_exp|, the paper's
   objective) is minimised over all frequencies of the click: by golden-section search
   (`fast`), or by the paper's GA (`ga`).
4. Uncertainty: the larger of the covariance's and the scatter of per-test estimates.
5. Talbott: one A_b per click minimising eq. 8 with the same globals.
6. Identifiability, trends, and validation (E_t, E_x, E_ẋ per test).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from shockdyno.errors import ConfigError, FitError
from shockdyno.fit.ga import GaSettings, run_ga
from shockdyno.fit.line_search import area_grid, golden_search, grid_search
from shockdyno.fit.prepare import OBJECTIVE_RATE_HZ, prepare_tests
from shockdyno.fit.problem import (
    DEFAULT_GLOBALS,
    DELAY_BOUND_S,
    DELAY_SCALE_S,
    GlobalParam,
    StackedProblem,
    delayed_motion,
    global_params,
    nominal_value,
)
from shockdyno.fit.result import ClickFit, FitResult
from shockdyno.fit.trend import polynomial_trend
from shockdyno.fit.validate import table4, validate_tests
from shockdyno.model import damper_force, evaluate
from shockdyno.model.spec import DamperSpec, default_spec_path, load_spec
from shockdyno.record.types import TestData

FloatArray = NDArray[np.float64]
Progress = Callable[[str, float], None]

AREA_SCALE = 1e-6  # m²: areas are optimised in mm²
OPTIMIZERS = ("fast", "ga")
# Identifiable: the area is pinned to within this relative 1-σ uncertainty, clear of zero,
# and the bleed passes at least this share of the flow (else the valve or the leak
# carry it and the data say little about the bleed).
MAX_RELATIVE_SD = 0.05
MIN_BLEED_SHARE = 0.02
MIN_COVERAGE = 0.1


@dataclass
class Calibration:
    overrides: dict[str, float]
    globals_sd: dict[str, float]
    a_bc: FloatArray
    a_bt: FloatArray
    sd_bc: FloatArray
    sd_bt: FloatArray
    tau: float  # variance inflation for correlated residuals
    nfev: int
    delay_s: float
    delay_sd_s: float
    cost_rms_n: float


def _overrides(params: Sequence[GlobalParam], theta: FloatArray) -> dict[str, float]:
    return {p.key: float(th * p.scale) for p, th in zip(params, theta, strict=True)}


def start_areas(
    prob: StackedProblem, spec: DamperSpec, a_max: float
) -> tuple[FloatArray, FloatArray]:
    """Each click's A_bc and A_bt minimising squared error, globals held at spec's."""
    n = prob.n_groups

    def sse(values: FloatArray) -> FloatArray:
        r = prob.force(spec, values[:n], values[n:]) - prob.f
        return prob.per_problem(r * r)

    lo, hi = grid_search(sse, 2 * n, area_grid(a_max))
    best, _ = golden_search(sse, lo, hi, iterations=25)
    return best[:n], best[n:]


def _autocorrelation_factor(r: FloatArray, test_id: NDArray[np.intp], max_lag: int = 40) -> float:
    """1 + 2 Σ ρ_k of the residuals (within tests), summed while ρ_k stays above 0.05.

    Least-squares covariance assumes independent residuals; correlated ones (model error,
    differentiation of a noisy x) carry fewer independent pieces of information, and the
    variance is scaled up by this factor, as for the mean of a correlated series.
    """
    denom = float(np.sum(r * r))
    if denom <= 0:
        return 1.0
    same = test_id[1:] == test_id[:-1]
    tau = 1.0
    for k in range(1, max_lag + 1):
        same_k = test_id[k:] == test_id[:-k] if k > 1 else same
        rho = float(np.sum(r[k:] * r[:-k] * same_k)) / denom
        if rho < 0.05:
            break
        tau += 2 * rho
    return tau


def calibrate(
    prob: StackedProblem,
    params: Sequence[GlobalParam],
    a_bc0: FloatArray,
    a_bt0: FloatArray,
    a_max: float,
    max_nfev: int = 60,
    robust: bool = True,
) -> Calibration:
    """Joint least squares over globals, channel delay and all areas (step 2 above).

    Unknowns, scaled to order 1: the spec globals / their scale, the delay in ms, and the
    areas in mm². The delay is not a damper parameter: it is reported apart.
    """
    n, ng = prob.n_groups, len(params) + 1  # the last global is the delay
    bound = DELAY_BOUND_S / DELAY_SCALE_S
    lb = np.concatenate([[p.lo for p in params], [-bound], np.zeros(2 * n)])
    ub = np.concatenate([[p.hi for p in params], [bound], np.full(2 * n, a_max / AREA_SCALE)])
    theta0 = np.array([nominal_value(prob.base, p.key) / p.scale for p in params] + [0.0])
    p0 = np.clip(np.concatenate([theta0, a_bc0 / AREA_SCALE, a_bt0 / AREA_SCALE]), lb, ub - 1e-12)
    in_group = [prob.group == g for g in range(n)]
    cache: dict[bytes, FloatArray] = {}

    def residual(p: FloatArray) -> FloatArray:
        key = p.tobytes()
        if key not in cache:
            cache.clear()
            spec = prob.spec_with(_overrides(params, p[: ng - 1]))
            a_bc, a_bt = p[ng : ng + n] * AREA_SCALE, p[ng + n :] * AREA_SCALE
            cache[key] = prob.force(spec, a_bc, a_bt, p[ng - 1] * DELAY_SCALE_S) - prob.f
        return cache[key]

    def jacobian(p: FloatArray) -> FloatArray:
        r0 = residual(p).copy()
        jac = np.zeros((r0.size, p.size))
        h = 1e-6 * np.maximum(np.abs(p), 0.1)
        h = np.where(p + h > ub, -h, h)
        for j in range(ng):
            q = p.copy()
            q[j] += h[j]
            jac[:, j] = (residual(q) - r0) / h[j]
        q = p.copy()
        q[ng:] += h[ng:]
        dr = residual(q) - r0
        # Which area a sample sees follows the sign of the delayed velocity.
        _, v = delayed_motion(prob.x_measured, prob.v_measured, prob.a, p[ng - 1] * DELAY_SCALE_S)
        comp, reb = v > 0, v < 0
        for g in range(n):
            rows_bc, rows_bt = in_group[g] & comp, in_group[g] & reb
            jac[rows_bc, ng + g] = dr[rows_bc] / h[ng + g]
            jac[rows_bt, ng + n + g] = dr[rows_bt] / h[ng + n + g]
        return jac

    common: dict[str, Any] = {
        "jac": jacobian,
        "bounds": (lb, ub),
        "method": "trf",
        "x_scale": "jac",
        "ftol": 1e-10,
        "xtol": 1e-10,
        "gtol": 1e-10,
        "max_nfev": max_nfev,
    }
    sol = least_squares(residual, p0, **common)
    nfev = int(sol.nfev)
    if robust:
        r = residual(sol.x)
        scale = 3 * 1.4826 * float(np.median(np.abs(r - np.median(r))))
        sol = least_squares(residual, sol.x, loss="soft_l1", f_scale=max(scale, 1e-3), **common)
        nfev += int(sol.nfev)
    p = sol.x
    r = residual(p)
    jac = jacobian(p)
    dof = max(r.size - p.size, 1)
    tau = _autocorrelation_factor(r, prob.test_id)
    s2 = float(np.sum(r * r)) / dof
    cov = np.linalg.pinv(jac.T @ jac) * s2 * tau
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    sd[~np.any(jac != 0, axis=0)] = np.inf  # no sample depends on it: not measured at all
    return Calibration(
        overrides=_overrides(params, p[: ng - 1]),
        globals_sd={pr.key: float(sd[i] * pr.scale) for i, pr in enumerate(params)},
        delay_s=float(p[ng - 1] * DELAY_SCALE_S),
        delay_sd_s=float(sd[ng - 1] * DELAY_SCALE_S),
        a_bc=p[ng : ng + n] * AREA_SCALE,
        a_bt=p[ng + n :] * AREA_SCALE,
        sd_bc=sd[ng : ng + n] * AREA_SCALE,
        sd_bt=sd[ng + n :] * AREA_SCALE,
        tau=tau,
        nfev=nfev,
        cost_rms_n=math.sqrt(float(np.mean(r * r))),
    )


def l1_problems(prob: StackedProblem, spec: DamperSpec) -> Callable[[FloatArray], FloatArray]:
    """Eq. 8 per (click, direction) problem for candidate areas [A_bc..., A_bt...]."""
    n = prob.n_groups

    def fun(values: FloatArray) -> FloatArray:
        return prob.per_problem(np.abs(prob.force(spec, values[:n], values[n:]) - prob.f))

    return fun


def polish_l1(
    prob: StackedProblem, spec: DamperSpec, a0: FloatArray, sd: FloatArray, a_max: float
) -> tuple[FloatArray, FloatArray]:
    """Eq. 8 minimised per click and direction, near the least-squares areas.

    Where the data are not what the model can produce (outliers, unmodelled physics) the
    eq. 8 optimum may lie far from the least-squares one, so a search over the whole
    range runs too and each problem keeps the better of the two.
    """
    fun = l1_problems(prob, spec)
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
    prob: StackedProblem, spec: DamperSpec, areas: FloatArray, a_max: float
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
        r = np.abs(prob.force(spec, values[:nt][tid], values[nt:][tid]) - prob.f)
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
    prob: StackedProblem, spec: DamperSpec, a_max: float
) -> Callable[[FloatArray], FloatArray]:
    """Eq. 8 per click for GA individuals u in [0, 1]², area = a_max u².

    u has shape (individuals, clicks, 2); all individuals are scored in one model call.
    """
    g = prob.group
    n, m = prob.n_groups, prob.size

    # Calls of ~20-40 k samples run fastest (per-call overhead vs cache misses).
    chunk = max(1, 30_000 // max(m, 1))

    def fitness(u: FloatArray) -> FloatArray:
        out = np.empty((u.shape[0], n))
        for lo in range(0, u.shape[0], chunk):
            part = u[lo : lo + chunk]
            k = part.shape[0]
            a = a_max * part * part
            bc = a[:, g, 0].ravel()
            bt = a[:, g, 1].ravel()
            x, v, acc = (np.tile(arr, k) for arr in (prob.x, prob.v, prob.a))
            prob.evaluations += 1
            prob.samples_evaluated += k * m
            r = np.abs(damper_force(spec, x, v, acc, bc, bt) - np.tile(prob.f, k))
            rows = np.repeat(np.arange(k), m) * n + np.tile(g, k)
            out[lo : lo + k] = np.bincount(rows, weights=r, minlength=k * n).reshape(k, n)
        return out

    return fitness


def talbott_areas(
    prob: StackedProblem, spec: DamperSpec, a_max: float, tau: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """One A_b per click minimising eq. 8: (A_b, its 1-σ uncertainty, eq. 8 there)."""

    def fun(values: FloatArray) -> FloatArray:
        return prob.per_group(np.abs(prob.force(spec, values, values) - prob.f))

    lo, hi = grid_search(fun, prob.n_groups, area_grid(a_max))
    a_b, obj = golden_search(fun, lo, hi, iterations=35)
    r0 = prob.force(spec, a_b, a_b) - prob.f
    h = np.maximum(1e-6 * a_b, 1e-13)
    dr = (prob.force(spec, a_b + h, a_b + h) - prob.f - r0) / h[prob.group]
    m = np.bincount(prob.group, minlength=prob.n_groups)
    s2 = prob.per_group(r0 * r0) / np.maximum(m - 1, 1)
    info = prob.per_group(dr * dr)
    with np.errstate(divide="ignore"):
        sd = np.where(info > 0, np.sqrt(tau * s2 / info), np.inf)
    return a_b, sd, obj


def _bleed_shares(
    prob: StackedProblem, spec: DamperSpec, a_bc: FloatArray, a_bt: FloatArray
) -> FloatArray:
    """Flow-weighted share of the bleed, per (click, direction) problem."""
    bd = evaluate(spec, prob.x, prob.v, prob.a, a_bc[prob.group], a_bt[prob.group])
    prob.evaluations += 1
    prob.samples_evaluated += prob.size
    w = np.abs(prob.v)
    with np.errstate(invalid="ignore", divide="ignore"):
        return prob.per_problem(bd.bleed_share * w) / prob.per_problem(w)


def _identifiable(a: float, sd: float, share: float, a_max: float, coverage: float) -> bool:
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


def _json_safe(obj: Any) -> Any:
    """Non-finite floats become None (JSON has no NaN or infinity)."""
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(obj) else None
    return obj


def fit_sweep(
    tests: list[TestData],
    spec_path: str | Path | None = None,
    optimizer: str = "fast",
    seed: int = 0,
    progress: Progress | None = None,
    *,
    global_keys: Sequence[str] = DEFAULT_GLOBALS,
    objective_rate_hz: float = OBJECTIVE_RATE_HZ,
    ga_settings: GaSettings | None = None,
) -> FitResult:
    """Calibrate globals, fit bleed areas per click, trend them and validate every test."""
    if optimizer not in OPTIMIZERS:
        raise ConfigError(f"unknown optimizer {optimizer!r} (choose {' or '.join(OPTIMIZERS)})")
    if not objective_rate_hz > 0:
        raise ConfigError("the objective's sample rate must be > 0")
    wall0 = time.perf_counter()
    ga_settings = ga_settings if ga_settings is not None else GaSettings()

    def report(stage: str, fraction: float) -> None:
        if progress is not None:
            progress(stage, fraction)

    path = Path(spec_path) if spec_path is not None else default_spec_path()
    base = load_spec(path)
    report("prepare", 0.0)
    prepared, notes = prepare_tests(tests, objective_rate_hz)
    if not prepared:
        raise FitError("no usable test to fit (each needs motion, force and 20 samples)")
    prob = StackedProblem(base, prepared)
    n = prob.n_groups
    a_max = base.bleed_bore_area_m2
    params = global_params(base, global_keys)

    report("start areas", 0.05)
    bc0, bt0 = start_areas(prob, base, a_max)
    report("calibrate globals", 0.15)
    cal = calibrate(prob, params, bc0, bt0, a_max)
    spec = prob.spec_with(cal.overrides)
    prob.set_delay(cal.delay_s)

    # The GA takes most of a `ga` fit's time, the calibration most of a `fast` one's.
    areas_start = 0.6 if optimizer == "fast" else 0.2
    report("bleed areas", areas_start)
    info: dict[str, Any] = {}
    l1 = l1_problems(prob, spec)
    if optimizer == "fast":
        areas, obj = polish_l1(
            prob,
            spec,
            np.concatenate([cal.a_bc, cal.a_bt]),
            np.concatenate([cal.sd_bc, cal.sd_bt]),
            a_max,
        )
        a_bc, a_bt = areas[:n], areas[n:]
    else:
        rng = np.random.default_rng(seed)
        gens = ga_settings.generations

        def on_gen(gen: int, _best: FloatArray) -> None:
            report("bleed areas (GA)", areas_start + (0.8 - areas_start) * gen / gens)

        ga = run_ga(ga_fitness(prob, spec, a_max), n, 2, rng, ga_settings, on_gen)
        a_bc, a_bt = a_max * ga.best[:, 0] ** 2, a_max * ga.best[:, 1] ** 2
        obj = l1(np.concatenate([a_bc, a_bt]))
        info["ga"] = {
            "population": ga_settings.population,
            "generations": gens,
            "elite_count": math.ceil(ga_settings.elite_fraction * ga_settings.population),
            "crossover_fraction": ga_settings.crossover_fraction,
            "variable_map": "A = A_bore * u^2, u in [0, 1]",
        }

    report("uncertainty", 0.8)
    sd_ls = np.concatenate([cal.sd_bc, cal.sd_bt])
    sd_scatter = between_test_sd(prob, spec, np.concatenate([a_bc, a_bt]), a_max)
    sd_all = np.fmax(sd_ls, sd_scatter)
    sd_bc, sd_bt = sd_all[:n], sd_all[n:]

    report("talbott", 0.85)
    a_b, sd_b, obj_tal = talbott_areas(prob, spec, a_max, cal.tau)
    shares = _bleed_shares(prob, spec, a_bc, a_bt)
    per_group = np.bincount(prob.group, minlength=n)
    cover = prob.per_problem(np.ones(prob.size)) / np.tile(np.maximum(per_group, 1), 2)

    clicks: list[ClickFit] = []
    for g, (c, gc) in enumerate(prob.keys):
        clicks.append(
            ClickFit(
                clicks=c,
                gas_clicks=gc,
                a_bc_m2=float(a_bc[g]),
                a_bt_m2=float(a_bt[g]),
                a_b_talbott_m2=float(a_b[g]),
                a_bc_sd_m2=float(sd_bc[g]),
                a_bt_sd_m2=float(sd_bt[g]),
                a_b_talbott_sd_m2=float(sd_b[g]),
                identifiable_bc=_identifiable(
                    float(a_bc[g]), float(sd_bc[g]), float(shares[g]), a_max, float(cover[g])
                ),
                identifiable_bt=_identifiable(
                    float(a_bt[g]),
                    float(sd_bt[g]),
                    float(shares[n + g]),
                    a_max,
                    float(cover[n + g]),
                ),
                objective_n=float(obj[g] + obj[n + g]),
                objective_talbott_n=float(obj_tal[g]),
                bleed_share_bc=float(shares[g]),
                bleed_share_bt=float(shares[n + g]),
            )
        )

    # The trend runs over rod clicks at one gas-bottle setting: the one with most clicks.
    gas_counts: dict[int, int] = {}
    for cf in clicks:
        gas_counts[cf.gas_clicks] = gas_counts.get(cf.gas_clicks, 0) + 1
    gas = min(gas_counts, key=lambda g: (-gas_counts[g], g))
    trend: dict[str, Any] = {}
    for name, attr, ok in (
        ("A_bc", "a_bc_m2", "identifiable_bc"),
        ("A_bt", "a_bt_m2", "identifiable_bt"),
    ):
        used = [cf for cf in clicks if getattr(cf, ok) and cf.gas_clicks == gas]
        t = polynomial_trend([cf.clicks for cf in used], [getattr(cf, attr) for cf in used])
        if t is not None:
            trend[name] = {**t, "gas_clicks": gas}

    report("validate", 0.9)
    result = FitResult(spec_path=str(path), globals=cal.overrides, clicks=clicks, trend=trend)
    result.info = {"calibration": {"force_delay_s": cal.delay_s}}
    result.tests = validate_tests(spec, result, prepared)
    info.update(
        {
            "optimizer": optimizer,
            "seed": seed,
            "wall_s": time.perf_counter() - wall0,
            "model_evaluations": prob.evaluations,
            "model_samples_evaluated": prob.samples_evaluated,
            "objective_rate_hz": objective_rate_hz,
            "objective_samples": prob.size,
            "objective_n": float(np.sum(obj)),
            "objective_talbott_n": float(np.sum(obj_tal)),
            "calibration": {
                "least_squares_evaluations": cal.nfev,
                "rms_residual_n": cal.cost_rms_n,
                "residual_correlation_factor": cal.tau,
                "force_delay_s": cal.delay_s,
                "force_delay_sd_s": cal.delay_sd_s,
                "globals_nominal": {p.key: nominal_value(base, p.key) for p in params},
                "globals_sd": cal.globals_sd,
            },
            "n_tests": len(prepared),
            "skipped": notes,
        }
    )
    info["table4"] = [row.as_dict() for row in table4(result)]
    result.info = _json_safe(info)
    result.tests = _json_safe(result.tests)
    report("done", 1.0)
    return result
