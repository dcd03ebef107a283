"""The static gas force of a recording's tests, and the damping force with it removed.

Dyno shops read damping force: the force minus the gas force that pushes the rod out at
rest. Click charts, peak-force plots and summaries show it with the gas force removed
(``--raw-force`` shows the force as measured).

**Measured.** A sweep measures the gas force at mid-stroke at rest at its start and after
each click change (run/gas_measure.py) and stores it with every test: ``gas_force_n``,
``gas_force_source = "measured"``.

**Estimated** (older and imported recordings). At a sine's reversals (x = ±A) the velocity
is zero, so the damping is gone, and the acceleration is ∓ω²A, so inertia terms cancel in
the mean of the two ends. For a gas spring linear over the stroke that mean is its force at
mid-stroke. The isothermal gas spring is slightly convex, so the mean reads high by
``p V0² / (V0² - (A_rod A)²)`` over ``p``: +1.3 N (0.6 %) at 30 mm on the simulated S46.
A closed bleed breaks it: the valves' preload makes the force jump at the reversal
(the simulated S46 at click 0 gives -40 to +250 N against 231 N) and holds the two ends
far apart (its valve keeps the pressure through the reversal), so the estimate of a gas
setting (the gas force does not depend on rod clicks) is the median over the tests whose
two ends are closest: those whose bleed lets the force relax. Only a recording of shut
bleeds alone is left with a wrong estimate. Marked ``gas_force_source = "estimated"``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from shockdyno.record.types import TestData
from shockdyno.report.summary import velocity
from shockdyno.units import SI, Units

FloatArray = NDArray[np.float64]

SPREAD_SLACK_N = 20.0  # reversal spreads this close to the closest test's count as alike
MEASURED = "measured"
ESTIMATED = "estimated"


def reversal_estimate(test: TestData) -> float:
    """The mean of the forces at the top and bottom reversals of the measured cycles (each
    the force interpolated where the velocity crosses zero); NaN without both."""
    top, bottom = reversal_forces(test)
    return (top + bottom) / 2


def reversal_forces(test: TestData) -> tuple[float, float]:
    """The mean force at the top (x > 0) and at the bottom reversals; NaN without both. A
    gas spring makes them differ by its rate over the stroke; a shut bleed, whose valve
    holds its pressure through the reversal, by far more."""
    m = test.measured()
    if m.t.size < 10:
        return math.nan, math.nan
    v = velocity(m.t, m.x)
    ok = np.isfinite(v[:-1]) & np.isfinite(v[1:])
    i = np.flatnonzero(ok & (np.sign(v[:-1]) * np.sign(v[1:]) < 0))
    if i.size < 2:
        return math.nan, math.nan
    w = v[i] / (v[i] - v[i + 1])
    force = m.force[i] + w * (m.force[i + 1] - m.force[i])
    x = m.x[i] + w * (m.x[i + 1] - m.x[i])
    top, bottom = force[x > 0], force[x < 0]
    if not (top.size and bottom.size):
        return math.nan, math.nan
    return float(np.mean(top)), float(np.mean(bottom))


def _estimate(pairs: Sequence[tuple[float, float]]) -> float:
    """A gas setting's estimate from its tests' (top, bottom) reversal forces: the median
    midpoint of the tests whose two ends are closest (within 1.5x the closest spread, plus
    20 N): those whose bleed lets the force relax through the reversal. A plain median was
    pulled to 132 N (against 231 N) by a sweep whose half of the tests had a shut bleed."""
    spread = np.array([abs(a - b) for a, b in pairs])
    mid = np.array([(a + b) / 2 for a, b in pairs])
    keep = spread <= 1.5 * float(np.min(spread)) + SPREAD_SLACK_N
    return float(np.median(mid[keep]))


def with_gas_force(tests: Sequence[TestData]) -> list[TestData]:
    """The tests, each with a gas force: its own measured one; else the median of those
    measured at the other clicks of its gas setting (a measurement at a shut bleed can be
    unusable: run/gas_measure.py), still "measured"; else the reversal estimate of its gas
    setting (module docstring), marked "estimated"."""
    measured: dict[int, list[float]] = {}
    estimates: dict[int, list[tuple[float, float]]] = {}
    for t in tests:
        if t.meta.gas_force_n is not None:
            if (t.meta.gas_force_source or MEASURED) == MEASURED:
                measured.setdefault(t.meta.gas_clicks, []).append(t.meta.gas_force_n)
            continue
        top, bottom = reversal_forces(t)
        if math.isfinite(top) and math.isfinite(bottom):
            estimates.setdefault(t.meta.gas_clicks, []).append((top, bottom))
    fill = {g: (_estimate(v), ESTIMATED) for g, v in estimates.items()}
    fill.update({g: (float(np.median(v)), MEASURED) for g, v in measured.items()})
    out = []
    for t in tests:
        if t.meta.gas_force_n is None and t.meta.gas_clicks in fill:
            value, source = fill[t.meta.gas_clicks]
            meta = replace(t.meta, gas_force_n=round(value, 2), gas_force_source=source)
            t = replace(t, meta=meta)
        out.append(t)
    return out


def gas_force_n(test: TestData) -> float:
    """The test's gas force (0 when neither stored nor estimated: nothing is removed)."""
    g = test.meta.gas_force_n
    return float(g) if g is not None and math.isfinite(g) else 0.0


def damping_force(test: TestData) -> FloatArray:
    """Force minus the test's gas force (call :func:`with_gas_force` first to estimate it)."""
    return np.asarray(test.force - gas_force_n(test), dtype=float)


def remove_gas(tests: Sequence[TestData]) -> list[TestData]:
    """The tests with force = damping force (gas force removed; estimated where not stored)."""
    return [replace(t, force=damping_force(t)) for t in with_gas_force(tests)]


def describe(tests: Sequence[TestData], units: Units = SI) -> str:
    """For captions and headers: 'gas force removed: 231 N measured at mid-stroke'."""
    values: dict[str, list[float]] = {}
    for t in tests:
        if t.meta.gas_force_n is not None:
            values.setdefault(t.meta.gas_force_source or MEASURED, []).append(t.meta.gas_force_n)
    if not values:
        return "gas force not removed: none measured and none could be estimated"
    parts = []
    for source, vals in sorted(values.items()):
        lo, hi = units.force(min(vals)), units.force(max(vals))
        f = units.force_label
        amount = f"{lo:.0f} {f}" if round(lo) == round(hi) else f"{lo:.0f}-{hi:.0f} {f}"
        where = (
            "measured at mid-stroke at rest"
            if source == MEASURED
            else "estimated from the sine's reversals"
        )
        parts.append(f"{amount} {where}")
    return "gas force removed: " + "; ".join(parts)
