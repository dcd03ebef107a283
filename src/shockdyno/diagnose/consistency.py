"""Is a claimed sensor lag one time for the whole sweep, as a sensor's is?

A channel delay or a load cell's lag shifts every test by the same time. Oil that gives
(aerated oil, a compliant chamber) delays the force too, but by a time that grows with
the chamber's pressure and the click's resistance: on reference-plant sweeps with 0.5 %
and 2 % air, the delay that best fitted each test alone ran 2-11 ms and 17-43 ms from
test to test, where a 2, 4 or 7 ms channel skew gave the same time within a millisecond
on every test. A sensor-lag candidate whose per-test delay spreads more than that is not
a sensor, whatever it explains.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import Fitted
from shockdyno.diagnose.workers import SERIAL, Workers
from shockdyno.fit.problem import StackedProblem
from shockdyno.model.composite import DamperModel, Term
from shockdyno.model.terms import LIBRARY

SCALES = np.linspace(0.0, 3.0, 61)  # the fitted sensor's times × these, tried on each test


@dataclass(frozen=True)
class DelaySpread:
    delays_s: list[float]  # the best delay of each test that places one
    lo_s: float
    hi_s: float
    median_s: float

    def sentence(self) -> str:
        return (
            f"the delay that fits each test alone runs {1e3 * self.lo_s:.3g}-"
            f"{1e3 * self.hi_s:.3g} ms from test to test: a sensor's is one time for the "
            "sweep, a lag that changes with the test is the damper's"
        )


def checked(name: str) -> bool:
    """Whether candidate `name` is a sensor that shifts the force against the motion in
    time (Term.time_shift): the checks below apply to it."""
    term = LIBRARY.get(name)
    return term is not None and term.sensor and bool(term.time_shift)


def _shifting(model: DamperModel) -> Term | None:
    """The model's sensor term that shifts the force in time (None without one)."""
    return next((t for t in model.terms if t.sensor and t.time_shift), None)


def _times(model: DamperModel, term: Term) -> dict[str, float]:
    return {t: model.value(term.qualified(t)) for t in term.time_shift}


def _net(term: Term, times: dict[str, float]) -> float:
    """The signed sum of the term's times: how far it moves the force against the motion."""
    return sum((sign * times[t] for t, sign in term.time_shift.items()), 0.0)


def _refined_minimum(points: np.ndarray, sse: np.ndarray) -> float:
    """The grid's least-squares point, refined by the parabola through its neighbours."""
    k = int(np.argmin(sse))
    if 0 < k < len(sse) - 1:
        a, b, c = sse[k - 1], sse[k], sse[k + 1]
        den = a - 2 * b + c
        if den > 0:
            return float(points[k] + 0.5 * (a - c) / den * (points[1] - points[0]))
    return float(points[k])


def delay_spread(
    data: Data,
    fitted: Fitted,
    min_gain: float,
    min_shift_s: float = 5e-4,
    workers: Workers = SERIAL,
) -> DelaySpread | None:
    """The time that fits each test alone: the fitted sensor's delay and lags scaled
    together (a sensor's form kept, so a load cell's lag is not read as a delay at a
    closed bleed's sharp reversal), everything else the fit found held. The time of a
    test is the scale × the sensor's net shift (delay + load-cell lag - LVDT lag). Only
    tests where their best scale removes at least `min_gain` of the squared error place
    it. None when the sensor shifts by less than `min_shift_s` (no time to compare) or
    fewer than three tests place it. The tests are independent: up to `workers`
    processes score them (workers.py)."""
    model = fitted.model
    term = _shifting(model)
    if term is None:
        return None
    values = _times(model, term)
    shift = _net(term, values)
    if abs(shift) < min_shift_s:
        return None
    tests = []
    for i in range(len(data.prepared)):
        one = data.subset([i])
        areas = fitted.covered_areas(one)
        if areas is not None:
            tests.append((one.prob.for_model(model, fitted.free), *areas))
    scaled = [{term.qualified(t): float(k) * v for t, v in values.items()} for k in SCALES]
    delays: list[float] = []
    for sse in workers.map(_scaled_sse, (model, scaled), tests):
        if sse[0] > 0 and float(np.min(sse)) <= (1 - min_gain) * sse[0]:
            delays.append(_refined_minimum(SCALES, sse) * shift)
    if len(delays) < 3:
        return None
    arr = np.asarray(delays)
    return DelaySpread(delays, float(np.min(arr)), float(np.max(arr)), float(np.median(arr)))


def _scaled_sse(
    shared: tuple[DamperModel, Sequence[dict[str, float]]],
    test: tuple[StackedProblem, NDArray[np.float64], NDArray[np.float64]],
) -> NDArray[np.float64]:
    """One test's squared error with the sensor's times at each of the scaled values."""
    model, scaled = shared
    prob, bc, bt = test
    sse = np.empty(len(scaled))
    for j, values in enumerate(scaled):
        r = prob.force(model.with_values(values), bc, bt) - prob.f
        sse[j] = float(r @ r)
    return sse


def net_shift_s(fitted: Fitted) -> float:
    """How far the sensor term moves the force against the motion: the signed sum of its
    times, e.g. delay + load-cell lag - LVDT lag (0 without the term)."""
    term = _shifting(fitted.model)
    return 0.0 if term is None else _net(term, _times(fitted.model, term))


def alike(fitted: Fitted, min_shift_s: float) -> str:
    """Why a sensor term that delays the force and the motion alike is not a sensor fault
    ("" when it shifts one against the other by at least `min_shift_s`). Every DAQ filters
    both channels before it samples them: on a clean reference-plant sweep (a 400 Hz
    anti-alias filter on each) the term took 0.66 ms of delay and 0.67 ms of LVDT lag,
    a net 0.04 ms, and 28 % of the held-out structure the sharp reversals leave."""
    if _shifting(fitted.model) is None:
        return ""
    shift = net_shift_s(fitted)
    if abs(shift) >= min_shift_s:
        return ""
    return (
        f"it delays the force and the motion alike (net {1e3 * shift:.2g} ms): both "
        "channels' filters, not a shift of one against the other"
    )


def inconsistent(spread: DelaySpread | None, abs_s: float, share: float) -> str:
    """Why the per-test delays are not one sensor's ("" when they are, or cannot say)."""
    if spread is None:
        return ""
    if spread.hi_s - spread.lo_s > abs_s + share * abs(spread.median_s):
        return spread.sentence()
    return ""
