"""The baseline: the paper's (or the given fit's) model refitted, with the gas spring
rate calibrated; and the spec values the recording calibrated, as the verdict lists them."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.data import Data
from shockdyno.diagnose.diagnosis import CalibrationRow, Trial
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.diagnose.settings import Settings
from shockdyno.fit.parameters import spec_global
from shockdyno.fit.result import FitResult
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import DamperSpec
from shockdyno.model.terms import make_term
from shockdyno.report.documents import Indistinguishable

FloatArray = NDArray[np.float64]
Progress = Callable[[str, float], None]


# The spec's own numbers that a sweep sees and a spec can only guess are calibrated in
# the baseline, never claimed as physics: the globals (gas charge, Coulomb friction,
# valve preloads and face areas, fit/problem.py) and the gas spring rate. A ±30 mm
# stroke pins the rate p0·n·A²/V, not n and V apart, so the gas volume carries it at the
# spec's (isothermal) index. A spec's gas volume is a guess within a factor of two;
# a rate that needs more than that is something else acting over the stroke (a bump
# stop, a top-out spring) and is left to the search.
GAS_VOLUME = "gas_spring.volume_factor"
GAS_VOLUME_RANGE = (0.5, 2.0)


def _baseline_fit(
    data: Data, fit: FitResult | None, settings: Settings, model: DamperModel, free: tuple[str, ...]
) -> Fitted:
    if fit is None:
        return refit(data, model, free, None, max_nfev=60)
    areas = {(c.clicks, c.gas_clicks, c.setting): (c.a_bc_m2, c.a_bt_m2) for c in fit.clicks}
    start = Fitted(model, (), areas, {}, np.zeros(0), np.zeros(0))
    return refit(data, model, free, start, max_nfev=settings.max_nfev)


def fit_baseline(data: Data, fit: FitResult | None, settings: Settings, notes: list[str]) -> Fitted:
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


def gas_spring_is_calibration(
    base: Fitted, claimed: list[str], trials: list[Trial], groups: list[Indistinguishable]
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
    groups[:] = [g for g in groups if "gas_spring" not in g.group]
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
