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
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.baseline import (
    GAS_VOLUME,
    calibration_rows,
    fit_baseline,
    gas_spring_is_calibration,
)
from shockdyno.diagnose.candidates import binned_means, folds
from shockdyno.diagnose.claims import effect_limit, separate_by
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.diagnosis import Diagnosis, ShortTest, TestScore, Trial
from shockdyno.diagnose.discover import discover
from shockdyno.diagnose.fitting import CALIBRATIONS, Fitted, full_rate_force, refit
from shockdyno.diagnose.locate import Location, locate
from shockdyno.diagnose.search import backward, final_refit, gated, run_round, search_subset
from shockdyno.diagnose.settings import Settings as Settings
from shockdyno.diagnose.spikes import remove_spikes
from shockdyno.diagnose.stats import MismatchStat, mismatch_test
from shockdyno.diagnose.workers import Workers
from shockdyno.errors import FitError
from shockdyno.fit.metrics import error_metrics
from shockdyno.fit.prepare import PreparedTest, prepare_tests, whole_cycles
from shockdyno.fit.result import FitResult
from shockdyno.fit.sweep import check_adjusters
from shockdyno.model.spec import DamperSpec, default_spec_path, load_spec
from shockdyno.record.types import TestData
from shockdyno.report.documents import Indistinguishable

FloatArray = NDArray[np.float64]
Progress = Callable[[str, float], None]


def _e_t(data: Data, fitted: Fitted) -> list[float]:
    out = []
    for p in data.prepared:
        f = full_rate_force(fitted, p)
        out.append(error_metrics(p.data.t, p.data.x, p.data.force, f, v=p.v, a=p.a)["E_t"])
    return out


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
    base = fit_baseline(data, fit, s, notes)
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
    groups: list[Indistinguishable] = []
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
        found, best, passed = run_round(
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
                by = "; ".join(dict.fromkeys(pairs))
                groups.append(Indistinguishable(group=tuple(group), separate_by=by))
            claimed.append(best.name)
            came_with[best.name] = tuple(k for k in best.fitted.globals if k not in base.globals)
            shapes.append((best.name, best.explained))
        base = best.fitted
        base_means, binned = binned_means(search, base.residual)
        left = mismatch_test(binned, rng, s.n_boot)
        remaining = [c for c in remaining if c != best.name]
    if len(claimed) >= 2:
        report("backward check", 0.92)
        base = backward(
            search, base, claimed, trials, groups, fold_list, rng, s, came_with, workers
        )
    report("scores", 0.95)
    if claimed or search is not data:
        base = final_refit(data, base, claimed, trials, groups, s, force_peak, came_with)
    gas_calibrated = GAS_VOLUME in baseline.free or gas_spring_is_calibration(
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
        limit = effect_limit(final_binned, force_peak, s)
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
    base = fit_baseline(data, fit, s, notes)
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
