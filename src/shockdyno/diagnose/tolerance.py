"""Calibration with limits: a spec value moved beyond a damper's tolerance is held at its
edge, and what it cannot take is left to the search as physics.

The diagnosis calibrates the spec values a sweep sees (fit/parameters.SPEC_GLOBALS). A
real damper departs from its drawing within a tolerance (`SpecGlobal.tolerance`, 0.5-2x
for the gas charge, the Coulomb friction and the valves); a calibration that needs more
stands in for physics the model lacks. Aerated oil beside seal stiction was reported as
compressibility and "the spec's Coulomb friction is 2.7x too small (calibrated, not
physics)": the Coulomb level had taken the stiction, so the friction term had nothing left
to explain. So whenever a fit of the search (the baseline, the fit after a claim) has
moved a value beyond its tolerance by more than 3σ, the value is held within it and the
fit refitted; every refit started from that one holds it too (`Fitted.limits`), so the
candidates are scored on the structure it could not take. The final refit frees it again
(`unhold`, from Search.final_refit): a claimed term that took its place keeps it there,
and one that did not is dropped by the final refit's rules; where the value still moves
beyond, the drawing is not the damper's (or the physics is not the library's), and the
model keeps the value the recording asks, reported as a finding, not a calibration. A
value within its tolerance is not bounded at all: trf scales its steps by the distance to
the bounds, and a bound that never binds still changes a short refit's path, and with it
the claims' held-out gains.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.fit.parameters import spec_global
from shockdyno.model.spec import DamperSpec

GAS_CHARGE = "gas_pressure_pa"


@dataclass(frozen=True)
class Asked:
    """A spec value a fit of the search moved beyond its tolerance: the value it asked
    for, its σ, the value the tolerance is about and the range it was then held within
    (SI)."""

    value: float
    sd: float
    reference: float
    limit: tuple[float, float]


def reference(data: Data, spec: DamperSpec, key: str) -> float:
    """What a value's tolerance is about: the spec's value; for the gas charge, the mean
    charge the tests were run at where the recording gives it (an operator who set a low
    charge on purpose wrote it down: a gauge reading, not a drawing's error)."""
    if key == GAS_CHARGE:
        gas = data.prob.inputs.gas_pressure_pa
        if gas is not None and np.any(np.isfinite(gas)):
            return float(np.mean(gas[np.isfinite(gas)]))
    return spec.value(key)


def limits_of(asked: Mapping[str, Asked]) -> dict[str, tuple[float, float]]:
    return {k: a.limit for k, a in asked.items()}


def beyond(data: Data, spec: DamperSpec, fitted: Fitted) -> dict[str, Asked]:
    """The calibrated spec values `fitted` moved beyond their tolerance by more than 3σ
    (a value already held is not asked again)."""
    out: dict[str, Asked] = {}
    for key in fitted.globals:
        tol = spec_global(key).tolerance
        ref = reference(data, spec, key)
        if tol is None or ref <= 0 or key in fitted.limits:
            continue
        lo, hi = tol[0] * ref, tol[1] * ref
        value = fitted.model.spec.value(key)
        sd = fitted.globals_sd.get(key, math.nan)
        edge = lo if value < lo else hi if value > hi else value
        off = abs(value - edge)
        if off > 0 and off > 3 * (sd if math.isfinite(sd) else 0.0):
            out[key] = Asked(value, sd, ref, (lo, hi))
    return out


def hold(
    data: Data,
    spec: DamperSpec,
    fitted: Fitted,
    asked: dict[str, Asked],
    max_nfev: int,
) -> Fitted:
    """`fitted`, or, where it moved a spec value beyond its tolerance, refitted with that
    value held within it (and with every value held before). Adds what was asked to
    `asked` (the first ask of each value is kept: the one the verdict reports)."""
    new = beyond(data, spec, fitted)
    if not new:
        return fitted
    for k, a in new.items():
        asked.setdefault(k, a)
    held = {**fitted.limits, **limits_of(new)}
    return refit(data, fitted.model, fitted.free, fitted, max_nfev=max_nfev, limits=held)


def unhold(
    data: Data,
    fitted: Fitted,
    asked: Mapping[str, Asked],
    taken: Mapping[str, float],
    max_nfev: int,
) -> Fitted:
    """The final refit of a search that held values: `fitted` (its end, limits dropped)
    refitted on `data` from where the search left it, from there with the held values at
    what they asked, and from there with the calibrations `taken` by the held search also
    back at their values before it: the best fit of these. From the held end a claim that
    took a value's place keeps it; but where a calibration took it instead (a bleed land
    beside a Coulomb friction held at its edge), trf from the held end can stop short of
    the value the recording asks. Neither other start is always the better one
    (benchmarks/results/calib-freed-2026-11-29.txt)."""
    back = {k: a.value for k, a in asked.items()}
    starts = [fitted.model, fitted.model.with_spec(fitted.model.spec.with_values(back))]
    if taken:
        starts.append(fitted.model.with_spec(fitted.model.spec.with_values({**back, **taken})))
    fits = [refit(data, m, fitted.free, fitted, max_nfev=max_nfev) for m in starts]
    return min(fits, key=lambda f: float(np.sum(f.residual**2)))
