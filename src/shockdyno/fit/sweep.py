"""Fit a sweep: calibrate the damper's globals and terms, then the bleed areas per click.

Stages (docs/fit-method.md has the why of each), each a function with a typed result:

1. `prepare_problem`: usable tests, stacked objective samples, the model with its terms.
2. Start: with the nominal globals, each click's A_bc and A_bt by a log grid and a
   golden-section search (compression samples depend on A_bc only, rebound on A_bt only).
3. `calibrate` (fit/calibrate.py): one least-squares problem over every test, unknowns
   the globals, the terms' free parameters and every click's areas.
4. `click_areas`: per click, with the globals fixed, eq. 8 (the paper's objective) over
   all frequencies of the click, by golden-section search (`fast`) or the paper's GA.
5. `click_fits`: uncertainty (the larger of the covariance's and the scatter of
   per-test estimates), Talbott's one A_b per click, bleed shares, identifiability.
6. `area_trends` and validation (E_t, E_x, E_ẋ per test, at the full rate).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shockdyno.errors import ConfigError, FitError
from shockdyno.fit.areas import (
    between_test_sd,
    bleed_shares,
    ga_fitness,
    identifiable,
    l1_problems,
    polish_l1,
    start_areas,
    talbott_areas,
)
from shockdyno.fit.calibrate import Calibration, calibrate
from shockdyno.fit.forces import TestForces, overlay_picks
from shockdyno.fit.forces import build as build_saved
from shockdyno.fit.ga import GaSettings, run_ga
from shockdyno.fit.parameters import DEFAULT_GLOBALS, Parameter, global_parameters
from shockdyno.fit.prepare import OBJECTIVE_RATE_HZ, PreparedTest, prepare_tests
from shockdyno.fit.problem import StackedProblem
from shockdyno.fit.result import ClickFit, FitResult
from shockdyno.fit.result_doc import CalibrationInfo, FitInfo, GaInfo
from shockdyno.fit.terms import TermSelection, parse_terms
from shockdyno.fit.trend import AreaTrend, polynomial_trend
from shockdyno.fit.validate import model_forces, scores, table4
from shockdyno.model.composite import DamperModel
from shockdyno.model.params import Estimate
from shockdyno.model.spec import DamperSpec, default_spec_path, load_spec
from shockdyno.record.types import TestData
from shockdyno.schema import finite_or_none

FloatArray = NDArray[np.float64]
Progress = Callable[[str, float], None]
OPTIMIZERS = ("fast", "ga")


@dataclass(frozen=True)
class Problem:
    spec_path: Path
    prepared: list[PreparedTest]
    notes: list[str]
    prob: StackedProblem
    model: DamperModel  # the base spec with the selected terms, at their start values
    selection: TermSelection
    params: list[Parameter]
    a_max: float


@dataclass(frozen=True)
class AreaFit:
    a_bc: FloatArray
    a_bt: FloatArray
    objective: FloatArray  # eq. 8 per (click, direction) problem
    ga_info: GaInfo | None = None  # with --optimizer ga


def prepare_problem(
    tests: Sequence[TestData],
    spec_path: str | Path | None,
    selection: TermSelection,
    global_keys: Sequence[str],
    objective_rate_hz: float,
) -> Problem:
    path = Path(spec_path) if spec_path is not None else default_spec_path()
    base = load_spec(path)
    check_adjusters(tests, base, path)
    prepared, notes = prepare_tests(tests, objective_rate_hz)
    if not prepared:
        why = "; ".join(notes[:3]) + (f"; and {len(notes) - 3} more" if len(notes) > 3 else "")
        raise FitError(
            "no usable test to fit (each needs motion, force and 20 samples): "
            + (why or f"{len(tests)} tests read (a recording cut off before its first test ended?)")
        )
    prob = StackedProblem(base, prepared)
    model = DamperModel(base, selection.terms)
    x = prob.inputs.x
    model = model.with_values(
        {t.qualified(k): v for t in model.terms for k, v in t.placed(x).items()}
    )
    return Problem(
        spec_path=path,
        prepared=prepared,
        notes=notes,
        prob=prob,
        model=model,
        selection=selection,
        params=global_parameters(base, global_keys),
        a_max=base.bleed_bore_area_m2,
    )


def check_adjusters(tests: Sequence[TestData], spec: DamperSpec, path: Path) -> None:
    """The recording's adjusters are the spec's: each area's trend follows the adjuster
    on its path, which only the spec names (a spec without them would trend both areas
    against the first adjuster's clicks). `fit` and `diagnose` both refuse a mismatch."""
    named = sorted({n for t in tests for n in t.meta.adjusters})
    if named != sorted(spec.adjuster_names):
        have = ", ".join(spec.adjuster_names) or "one rod adjuster"
        raise FitError(
            f"the tests name adjusters {', '.join(named) or 'none (one rod adjuster)'}; "
            f"the spec {path} has {have}: give the damper's own spec with --spec"
        )


def click_areas(
    pb: Problem,
    model: DamperModel,
    cal: Calibration,
    optimizer: str,
    seed: int,
    ga_settings: GaSettings,
    on_gen: Callable[[int, FloatArray], None] | None = None,
) -> AreaFit:
    prob, n, a_max = pb.prob, pb.prob.n_groups, pb.a_max
    if optimizer == "fast":
        areas, obj = polish_l1(
            prob,
            model,
            np.concatenate([cal.a_bc, cal.a_bt]),
            np.concatenate([cal.sd_bc, cal.sd_bt]),
            a_max,
        )
        return AreaFit(areas[:n], areas[n:], obj)
    rng = np.random.default_rng(seed)
    ga = run_ga(ga_fitness(prob, model, a_max), n, 2, rng, ga_settings, on_gen)
    a_bc, a_bt = a_max * ga.best[:, 0] ** 2, a_max * ga.best[:, 1] ** 2
    obj = l1_problems(prob, model)(np.concatenate([a_bc, a_bt]))
    info = GaInfo(
        population=ga_settings.population,
        generations=ga_settings.generations,
        elite_count=math.ceil(ga_settings.elite_fraction * ga_settings.population),
        crossover_fraction=ga_settings.crossover_fraction,
        variable_map="A = A_bore * u^2, u in [0, 1]",
    )
    return AreaFit(a_bc, a_bt, obj, info)


def click_fits(
    pb: Problem, model: DamperModel, cal: Calibration, areas: AreaFit
) -> tuple[list[ClickFit], FloatArray]:
    """Each click's areas with uncertainty, Talbott's A_b, shares; and Talbott's eq. 8."""
    prob, n, a_max = pb.prob, pb.prob.n_groups, pb.a_max
    a_bc, a_bt = areas.a_bc, areas.a_bt
    sd_ls = np.concatenate([cal.sd_bc, cal.sd_bt])
    sd_scatter = between_test_sd(prob, model, np.concatenate([a_bc, a_bt]), a_max)
    sd_all = np.fmax(sd_ls, sd_scatter)
    sd_bc, sd_bt = sd_all[:n], sd_all[n:]
    a_b, sd_b, obj_tal = talbott_areas(prob, model, a_max, cal.tau)
    shares = bleed_shares(prob, model, a_bc, a_bt)
    per_group = np.bincount(prob.group, minlength=n)
    cover = prob.per_problem(np.ones(prob.size)) / np.tile(np.maximum(per_group, 1), 2)
    obj = areas.objective
    clicks = [
        ClickFit(
            clicks=c,
            gas_clicks=gc,
            a_bc_m2=float(a_bc[g]),
            a_bt_m2=float(a_bt[g]),
            a_b_talbott_m2=float(a_b[g]),
            a_bc_sd_m2=float(sd_bc[g]),
            a_bt_sd_m2=float(sd_bt[g]),
            a_b_talbott_sd_m2=float(sd_b[g]),
            identifiable_bc=identifiable(
                float(a_bc[g]), float(sd_bc[g]), float(shares[g]), a_max, float(cover[g])
            ),
            identifiable_bt=identifiable(
                float(a_bt[g]), float(sd_bt[g]), float(shares[n + g]), a_max, float(cover[n + g])
            ),
            objective_n=float(obj[g] + obj[n + g]),
            objective_talbott_n=float(obj_tal[g]),
            bleed_share_bc=float(shares[g]),
            bleed_share_bt=float(shares[n + g]),
            adjusters=dict(setting),
        )
        for g, (c, gc, setting) in enumerate(prob.keys)
    ]
    return clicks, obj_tal


def area_trends(clicks: Sequence[ClickFit], spec: DamperSpec | None = None) -> dict[str, AreaTrend]:
    """Trend of the identifiable areas vs rod clicks, at the gas setting with most clicks.

    On a damper with several adjusters each area against the clicks of the adjuster
    acting on its path (A_bc against the compression adjuster's), over every setting:
    the other adjusters do not touch that path, so each setting is one more measurement."""
    gas_counts: dict[int, int] = {}
    for cf in clicks:
        gas_counts[cf.gas_clicks] = gas_counts.get(cf.gas_clicks, 0) + 1
    gas = min(gas_counts, key=lambda g: (-gas_counts[g], g))
    trend: dict[str, AreaTrend] = {}
    for name, attr, ok in (
        ("A_bc", "a_bc_m2", "identifiable_bc"),
        ("A_bt", "a_bt_m2", "identifiable_bt"),
    ):
        used = [cf for cf in clicks if getattr(cf, ok) and cf.gas_clicks == gas]
        by = spec.adjuster_on("compression" if name == "A_bc" else "rebound") if spec else ""
        if by:
            used = [cf for cf in used if by in cf.adjusters]
        x = [cf.adjusters[by] if by else cf.clicks for cf in used]
        t = polynomial_trend(x, [getattr(cf, attr) for cf in used])
        if t is not None:
            trend[name] = replace(t, gas_clicks=gas, adjuster=by)
    return trend


def term_estimates(model: DamperModel, cal: Calibration) -> dict[str, dict[str, Estimate]]:
    """Every term parameter: fitted ones with their σ (flagged at a bound), held ones fixed."""
    out: dict[str, dict[str, Estimate]] = {}
    for term in model.terms:
        params: dict[str, Estimate] = {}
        for p in term.params():
            q = term.qualified(p.name)
            value = model.value(q)
            if q in cal.term_values:
                span = p.hi - p.lo
                near = min(abs(value - p.lo), abs(p.hi - value)) <= 1e-3 * span
                params[p.name] = Estimate(value, cal.term_sd[q], p.unit, at_bound=near)
            else:
                params[p.name] = Estimate(value, float("nan"), p.unit, fixed=True)
        out[term.name] = params
    return out


# The nominal start is kept unless it ends worse than the plain fit by more than this
# share of the RMS residual: below it, the difference is the optimiser's, not the model's
# (held parameters at their nominal values are what the user asked for).
NO_WORSE_RTOL = 1e-4


def calibrate_never_worse(
    pb: Problem, bc0: FloatArray, bt0: FloatArray, report: Progress
) -> tuple[Calibration, DamperModel, str]:
    """The calibration, and a fit with terms no worse than the paper's model alone.

    With free term parameters, three starts: the terms at their nominal ("on") values
    (finds an effect whose gradient vanishes at off, a cavitation threshold no sample
    reaches); the plain fit with every term at its off value (the paper's model
    exactly); and the terms freed from that plain optimum. The nominal start is kept
    when it ends no worse than the plain fit; otherwise the better of the other two, so
    adding a term never ends above the plain fit, and a held parameter that made the term
    unable to reach off (the oil's compressibility beside the air, on rigid oil) is held
    at its off value instead. Returns the calibration, the model it calibrated (its
    values apply on top) and which start won.
    """
    prob, free = pb.prob, pb.selection.free  # prob: for pb.model with `free` varied
    on = calibrate(prob, pb.model, pb.params, free, bc0, bt0, pb.a_max)
    off_model = pb.model.off()
    if not free or all(pb.model.value(q) == p.off for q, p in pb.model.param_list()):
        # Nothing to vary, or every term already starts at off (the default channel
        # delay): the plain start is the one just run.
        return on, on.model(prob, pb.model), "nominal"
    report("calibrate globals (plain start)", 0.3)
    plain = calibrate(prob.for_model(off_model), off_model, pb.params, (), bc0, bt0, pb.a_max)
    from_plain_model = plain.model(prob, off_model)
    report("calibrate globals (terms from the plain fit)", 0.45)
    # The globals start from the plain fit's (overrides are absolute values, so the
    # result applies to the original spec alike).
    from_plain = prob.with_base(from_plain_model.spec).for_model(from_plain_model, free)
    freed = calibrate(
        from_plain, from_plain_model, pb.params, free, plain.a_bc, plain.a_bt, pb.a_max
    )
    # The plain fit as a candidate: the free parameters at off, not estimated.
    plain_off = replace(
        plain,
        term_values={q: off_model.value(q) for q in free},
        term_sd={q: math.nan for q in free},
    )
    if on.cost_rms_n <= (1 + NO_WORSE_RTOL) * plain.cost_rms_n:
        # The terms as asked (held parameters at their nominal values) are no worse.
        return on, on.model(prob, pb.model), "nominal"
    options = [
        (freed, off_model, "plain fit, terms freed"),
        (plain_off, off_model, "plain fit (terms at off)"),
    ]
    cal, base, start = min(options, key=lambda o: o[0].cost_rms_n)
    return cal, cal.model(prob, base), start


def fit_sweep(
    tests: list[TestData],
    spec_path: str | Path | None = None,
    optimizer: str = "fast",
    seed: int = 0,
    progress: Progress | None = None,
    *,
    terms: str | TermSelection | None = None,
    global_keys: Sequence[str] = DEFAULT_GLOBALS,
    objective_rate_hz: float = OBJECTIVE_RATE_HZ,
    ga_settings: GaSettings | None = None,
) -> FitResult:
    """Calibrate globals and terms, fit bleed areas per click, trend them, validate."""
    if optimizer not in OPTIMIZERS:
        raise ConfigError(f"unknown optimizer {optimizer!r} (choose {' or '.join(OPTIMIZERS)})")
    if not objective_rate_hz > 0:
        raise ConfigError("the objective's sample rate must be > 0")
    selection = terms if isinstance(terms, TermSelection) else parse_terms(terms)
    wall0 = time.perf_counter()
    ga_settings = ga_settings if ga_settings is not None else GaSettings()

    def report(stage: str, fraction: float) -> None:
        if progress is not None:
            progress(stage, fraction)

    report("prepare", 0.0)
    pb = prepare_problem(tests, spec_path, selection, global_keys, objective_rate_hz)
    prob = pb.prob.for_model(pb.model, selection.free)
    pb = replace(pb, prob=prob)
    report("start areas", 0.05)
    bc0, bt0 = start_areas(prob, pb.model, pb.a_max)
    report("calibrate globals", 0.15)
    cal, model, start = calibrate_never_worse(pb, bc0, bt0, report)
    model, cal = _unseen_off(model, cal, prob)
    prob = prob.for_model(model)  # nothing is varied now but the areas
    pb = replace(pb, prob=prob)

    # The GA takes most of a `ga` fit's time, the calibration most of a `fast` one's.
    areas_start = 0.6 if optimizer == "fast" else 0.2
    report("bleed areas", areas_start)

    def on_gen(gen: int, _best: FloatArray) -> None:
        report(
            "bleed areas (GA)", areas_start + (0.8 - areas_start) * gen / ga_settings.generations
        )

    areas = click_areas(pb, model, cal, optimizer, seed, ga_settings, on_gen)
    report("uncertainty and talbott", 0.8)
    clicks, obj_tal = click_fits(pb, model, cal, areas)
    trend = area_trends(clicks, pb.model.spec)

    report("validate", 0.9)
    estimates = term_estimates(model, cal)
    result = FitResult(
        spec_path=str(pb.spec_path),
        globals=cal.overrides,
        clicks=clicks,
        trend=trend,
        terms=estimates,
    )
    _validate_and_save(result, pb, tests)
    info = _fit_info(
        pb,
        cal,
        start,
        areas,
        obj_tal,
        estimates,
        optimizer=optimizer,
        seed=seed,
        objective_rate_hz=objective_rate_hz,
        wall0=wall0,
    )
    result.info = replace(info, table4=tuple(row.doc() for row in table4(result)))
    report("done", 1.0)
    return result


def _validate_and_save(result: FitResult, pb: Problem, tests: list[TestData]) -> None:
    """The fitted model's scores on every test, and what a report draws of the model
    (fit/forces.py), computed here once from the same forces."""
    forces = model_forces(result.model(), result, pb.prepared)
    result.tests = scores(forces)
    picks = overlay_picks(result, [p.data.meta for p in pb.prepared])
    result.saved = build_saved(
        result,
        [
            TestForces(f.test.meta.index, f.proposed, f.talbott)
            for f in forces
            if f.test.meta.index in picks
        ],
        tests,
    )


def _unseen_off(
    model: DamperModel, cal: Calibration, prob: StackedProblem
) -> tuple[DamperModel, Calibration]:
    """The model with each term's parameters the data do not measure at their off values
    (`unseen`), and the calibration with those parameters' σ infinite."""
    unseen = {
        t.qualified(k): v
        for t in model.terms
        for k, v in t.unseen(model.local_values(t), prob.inputs.x).items()
    }
    model = model.with_values(unseen)
    # Reported off because the data do not measure them: no σ from the calibration's
    # curvature stands for that (at an edge of the stroke it came out 1.6e-6 N on 50 kN).
    cal = replace(cal, term_sd=cal.term_sd | {q: math.inf for q in unseen if q in cal.term_sd})
    return model, cal


def _fit_info(
    pb: Problem,
    cal: Calibration,
    start: str,
    areas: AreaFit,
    obj_tal: FloatArray,
    estimates: dict[str, dict[str, Estimate]],
    *,
    optimizer: str,
    seed: int,
    objective_rate_hz: float,
    wall0: float,
) -> FitInfo:
    """The fit's `info` (docs/fit.md) but Table 4: how it ran (the wall time since
    `wall0`), what it cost, the calibration's start and residual, the tests used and
    skipped."""
    prob, selection = pb.prob, pb.selection
    delay = estimates.get("sensor_lag", {}).get("delay_s")
    return FitInfo(
        ga=areas.ga_info,
        optimizer=optimizer,
        seed=seed,
        terms=tuple(selection.names),
        free_term_parameters=tuple(selection.free),
        wall_s=finite_or_none(time.perf_counter() - wall0),
        model_evaluations=prob.evaluations,
        model_samples_evaluated=prob.samples_evaluated,
        objective_rate_hz=finite_or_none(objective_rate_hz),
        objective_samples=prob.size,
        objective_n=finite_or_none(np.sum(areas.objective)),
        objective_talbott_n=finite_or_none(np.sum(obj_tal)),
        calibration=CalibrationInfo(
            least_squares_evaluations=cal.nfev,
            start=start,
            rms_residual_n=finite_or_none(cal.cost_rms_n),
            residual_correlation_factor=finite_or_none(cal.tau),
            # Kept for readers of older results: the sensor_lag term's delay.
            force_delay_s=finite_or_none(delay.value) if delay is not None else 0.0,
            force_delay_sd_s=finite_or_none(delay.sd) if delay is not None else None,
            globals_nominal={
                p.name: finite_or_none(pb.model.spec.value(p.name)) for p in pb.params
            },
            globals_sd={k: finite_or_none(v) for k, v in cal.globals_sd.items()},
        ),
        n_tests=len(pb.prepared),
        skipped=tuple(pb.notes),
    )
