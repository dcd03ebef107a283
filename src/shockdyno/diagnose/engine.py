"""The diagnosis: locate the mismatch, name the missing physics, model it, refit.

1. Baseline (baseline.py): the paper's model (or a given fit's model) refitted to the
   recording, each spec value a term calibrates (Term.calibrates) calibrated; its
   residual is split into structure and noise (cycles.py) and tested (stats.py), and the
   structure located (locate.py).
2. Forward selection (search.py's Search; its claim rules in claims.py): each library
   term not yet in the model is added and refitted jointly with the globals and areas
   (fitting.py); scored by a bootstrap likelihood ratio (p-value) and by held-out
   prediction (leave one frequency out, one click out, or one half of a single test). A
   term is claimed when both agree (p < alpha and a held-out gain of at least
   `min_gain`, or `min_gain_joining` once a term is claimed) and its effect is material;
   candidates whose explained structure has the same shape are reported as
   indistinguishable. The claimed term joins the model and the search repeats on what
   remains.
3. Open set: a generic form (Term.open_set: `position_force`) competes as a candidate,
   but is claimed only when no named term is; what no candidate explains is reported as
   the unexplained regions.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.baseline import calibrate, fit_baseline
from shockdyno.diagnose.candidates import binned_means
from shockdyno.diagnose.claims import effect_limit
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.diagnosis import Diagnosis, ShortTest, TestScore
from shockdyno.diagnose.discover import Described, discover
from shockdyno.diagnose.fitting import Fitted, full_rate_force
from shockdyno.diagnose.locate import Location, locate
from shockdyno.diagnose.search import Search
from shockdyno.diagnose.settings import Settings as Settings
from shockdyno.diagnose.spikes import remove_spikes
from shockdyno.diagnose.stats import MismatchStat, mismatch_test
from shockdyno.diagnose.tolerance import Asked, hold
from shockdyno.diagnose.workers import Workers
from shockdyno.errors import FitError
from shockdyno.fit.metrics import error_metrics
from shockdyno.fit.prepare import PreparedTest, prepare_tests, whole_cycles
from shockdyno.fit.result import FitResult
from shockdyno.fit.sweep import check_adjusters
from shockdyno.model.spec import DamperSpec, default_spec_path, load_spec
from shockdyno.record.types import TestData

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
    report: Progress = progress if progress is not None else _quiet
    report("prepare", 0.0)
    tests, spikes = remove_spikes(tests)
    sensor = [spikes.sentence()] if spikes is not None else []
    prepared, notes = _usable(tests, s)
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
    drawing = load_spec(fit.spec_file()) if fit else spec  # what the tolerances are about
    asked: dict[str, Asked] = {}  # spec values a fit moved beyond them, held in the search
    baseline = fit_baseline(data, fit, s, notes)
    held = hold(data, drawing, baseline, asked, 60)
    _, binned = binned_means(data, held.residual)
    mismatch = mismatch_test(binned, rng, s.n_boot)
    location = locate(data, binned, s)
    search = Search.over(data, held, mismatch, s, rng, report, workers, limits=(drawing, asked))
    calibration = calibrate(drawing, baseline, search, asked, data)
    remaining, unexplained, described = _left(search, data, rng, report)
    freqs = {round(p.data.meta.frequency_hz, 3) for p in data.prepared}
    report("done", 1.0)
    return Diagnosis(
        mismatch=mismatch,
        location=location,
        trials=search.trials,
        claimed=search.claimed,
        indistinguishable=search.groups,
        unexplained=unexplained,
        remaining=remaining,
        tests=_scores(data, baseline, search.base),
        baseline=baseline,
        final=search.base,
        data=data,
        notes=notes,
        wall_s=time.perf_counter() - wall0,
        single_frequency=len(freqs) == 1,
        calibration=calibration,
        settings=s,
        sensor=sensor,
        short_tests=short,
        described=described,
        held=tuple(held.limits),
    )


def _usable(tests: Sequence[TestData], s: Settings) -> tuple[list[PreparedTest], list[str]]:
    """The tests prepared for the fit, and notes on those left out (an error: none left)."""
    prepared, notes = prepare_tests(list(tests), s.objective_rate_hz, phase_locked=True)
    if not prepared:
        raise FitError(
            "no usable test to diagnose (each needs motion, force and 20 samples): "
            + "; ".join(notes[:3])
            + (f"; and {len(notes) - 3} more" if len(notes) > 3 else "")
        )
    return prepared, notes


def _scores(data: Data, baseline: Fitted, final: Fitted) -> list[TestScore]:
    before, after = _e_t(data, baseline), _e_t(data, final)
    return [
        TestScore(p.data.meta.index, p.data.meta.clicks, p.data.meta.frequency_hz, b, a)
        for p, b, a in zip(data.prepared, before, after, strict=True)
    ]


def _left(
    search: Search, data: Data, rng: np.random.Generator, report: Progress
) -> tuple[MismatchStat, Location, list[Described]]:
    """What the final model leaves on every test: its mismatch statistic, where it lies
    (when significant), and what it follows, with a discovered term (discover.py)."""
    s, final = search.s, search.base
    _, final_binned = binned_means(data, final.residual)
    remaining = mismatch_test(final_binned, rng, s.n_boot)
    unexplained = locate(data, final_binned, s) if remaining.p_value < s.alpha else Location([], {})
    # -- physics outside the library (issue 45): describe what is left, try a form for it
    described = []
    if unexplained.regions:
        report("unexplained: described", 0.97)
        limit = effect_limit(final_binned, search.force_peak, s)
        rms = remaining.structured_rms_n
        described = [discover(data, final, final_binned, unexplained, rms, s, limit)]
    # -- end of the hook
    return remaining, unexplained, described


def _quiet(stage: str, fraction: float) -> None:
    pass


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
