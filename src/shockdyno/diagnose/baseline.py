"""The baseline: the paper's (or the given fit's) model refitted, with each term's factor
on a spec value calibrated (Term.calibrates: the gas spring's volume); and the spec
values the recording calibrated, as the verdict lists them."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from shockdyno.diagnose.data import Data
from shockdyno.diagnose.diagnosis import CalibrationRow, Trial
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.tolerance import Asked, pinned, reference
from shockdyno.fit.parameters import spec_global
from shockdyno.fit.result import FitResult
from shockdyno.model.composite import DamperModel, Term
from shockdyno.model.spec import DamperSpec
from shockdyno.model.terms import LIBRARY, make_term
from shockdyno.report.documents import Indistinguishable

if TYPE_CHECKING:  # search.py imports what the baseline does; only its type is read here
    from shockdyno.diagnose.search import Search

# The spec's own numbers that a sweep sees and a spec can only guess are calibrated in
# the baseline, never claimed as physics: the globals (gas charge, Coulomb friction,
# valve preloads and face areas, fit/problem.py) and a term's factor on a spec value
# within a spec's error (Term.calibrates: the gas spring rate, carried by the gas volume).


def _baseline_fit(
    data: Data, fit: FitResult | None, settings: Settings, model: DamperModel, free: tuple[str, ...]
) -> Fitted:
    if fit is None:
        return refit(data, model, free, None, max_nfev=60)
    areas = {(c.clicks, c.gas_clicks, c.setting): (c.a_bc_m2, c.a_bt_m2) for c in fit.clicks}
    start = Fitted(model, (), areas, {}, np.zeros(0), np.zeros(0))
    return refit(data, model, free, start, max_nfev=settings.max_nfev)


def _factor(fitted: Fitted, term: Term) -> float:
    """The term's calibrated factor as `fitted` (Term.calibrates.param)."""
    assert term.calibrates is not None
    return fitted.model.value(term.qualified(term.calibrates.param))


def _within(factor: float, term: Term) -> bool:
    assert term.calibrates is not None
    lo, hi = term.calibrates.within
    return lo <= factor <= hi


def fit_baseline(data: Data, fit: FitResult | None, settings: Settings, notes: list[str]) -> Fitted:
    """The paper's model (or the given fit's) refitted, with each library term that
    calibrates a spec value (Term.calibrates) added and its factor freed, unless the fit
    already carries the term, the search may not try it, or the factor comes out beyond
    a spec's error (then a note says so and the term is left to the search)."""
    model = DamperModel(data.prob.base) if fit is None else fit.model()
    terms = [
        make_term(name)
        for name, cls in LIBRARY.items()
        if cls.calibrates is not None and model.term(name) is None and name in settings.candidates
    ]
    while terms:
        with_terms = DamperModel(model.spec, (*model.terms, *terms), model.values)
        keys = tuple(t.qualified(t.calibrates.param) for t in terms if t.calibrates)
        calibrated = _baseline_fit(data, fit, settings, with_terms, keys)
        beyond = [t for t in terms if not _within(_factor(calibrated, t), t)]
        if not beyond:
            return calibrated
        for t in beyond:
            assert t.calibrates is not None
            notes.append(
                f"{t.calibrates.effect} would need a {t.calibrates.quantity} "
                f"{_factor(calibrated, t):.2g}× the spec's, beyond a spec's error: not "
                "calibrated, left to the search"
            )
        terms = [t for t in terms if t not in beyond]
    return _baseline_fit(data, fit, settings, model, ())


def spec_calibrated(
    baseline: Fitted,
    final: Fitted,
    claimed: list[str],
    trials: list[Trial],
    groups: list[Indistinguishable],
) -> list[Term]:
    """The terms of the final model whose factor is the spec's error (Term.calibrates):
    calibrated in the baseline, or claimed at a factor within a spec's error.

    The baseline calibrates the gas volume unless the plain model wants it beyond a spec's
    reach; with air in the oil it can (the air softens the stroke), and once the air is
    claimed the gas spring joins at the spec's volume give or take a few per cent (0.972x
    in a CI run): the spec's error, not a second physics. It stays in the model, and the
    verdict lists it under calibration: it leaves `claimed`, its trial and `groups`."""
    out = []
    for term in final.model.terms:
        cal = term.calibrates
        if cal is None:
            continue
        if term.qualified(cal.param) in baseline.free:
            out.append(term)
        elif term.name in claimed and _within(_factor(final, term), term):
            claimed.remove(term.name)
            for f in trials:
                if f.claimed and f.physics == term.name:
                    f.claimed = False
                    f.why_not = (
                        f"a {cal.quantity} {_factor(final, term):.3g}x the spec's is within "
                        "a spec's error: calibration, not physics"
                    )
            groups[:] = [g for g in groups if term.name not in g.group]
            out.append(term)
    return out


def calibration_rows(
    spec: DamperSpec,
    fitted: Fitted,
    terms: Sequence[Term],
    share: float,
    asked: Mapping[str, Asked] | None = None,
    data: Data | None = None,
) -> list[CalibrationRow]:
    """The spec's values against what the recording calibrated them to; each spec value
    a term's factor calibrated (`terms`, spec_calibrated: not when a claimed term's
    physics moved it), with a spec's error (SpecCalibration.within) as its tolerance:
    a factor the search's refits walked beyond it is a finding, not a calibration.
    `asked`: the values a fit of the search asked beyond their tolerance (tolerance.py;
    a term's factor by its qualified name); `data`: the recording, whose written gas
    charge the charge's tolerance is about."""
    got = fitted.model.spec
    asked = asked or {}
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
            asked[key].value if key in asked else math.nan,
            reference(data, spec, key) if data is not None else math.nan,
            spec_global(key).bounds(spec.value(key)),
        )
        for key in fitted.globals
    ]
    for term in terms:
        cal = term.calibrates
        assert cal is not None
        q = term.qualified(cal.param)
        v0 = spec.value(cal.spec_key)
        # At an end of its range the factor is no estimate and a bound's σ no error bar:
        # the row is then judged by its value alone (beyond a spec's error: a finding).
        sd = math.nan if pinned(fitted, term) else fitted.term_sd.get(q, math.nan)
        got_v = v0 * _factor(fitted, term)
        was = v0 * asked[q].value if q in asked else math.nan
        row = CalibrationRow(
            cal.spec_key, v0, got_v, v0 * sd, cal.unit, share, tolerance=cal.within, asked=was
        )
        rows.append(row)
    return rows


def calibrate(
    spec: DamperSpec,
    baseline: Fitted,
    search: Search,
    asked: Mapping[str, Asked] | None = None,
    data: Data | None = None,
) -> list[CalibrationRow]:
    """The spec values the recording calibrated, once the search is done (`spec`: the one
    the recording names, the drawing the tolerances are about): a term whose factor is
    the spec's error leaves the search's claims, trials and groups (spec_calibrated) and
    is listed with the globals (calibration_rows), with what a fit `asked` beyond a
    tolerance and `data`, the recording (its written gas charge)."""
    terms = spec_calibrated(baseline, search.base, search.claimed, search.trials, search.groups)
    return calibration_rows(spec, search.base, terms, search.s.calibration_share, asked, data)
