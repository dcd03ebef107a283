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
(the simulated S46 at click 0 gives -40 to +250 N against 231 N), so the estimate is the
median over the tests of one gas setting (the gas force does not depend on rod clicks):
the open-bleed tests outvote the closed ones. Marked ``gas_force_source = "estimated"``.
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

MEASURED = "measured"
ESTIMATED = "estimated"


def reversal_estimate(test: TestData) -> float:
    """The mean of the forces at the top and bottom reversals of the measured cycles (each
    the force interpolated where the velocity crosses zero); NaN without both."""
    m = test.measured()
    if m.t.size < 10:
        return math.nan
    v = velocity(m.t, m.x)
    ok = np.isfinite(v[:-1]) & np.isfinite(v[1:])
    i = np.flatnonzero(ok & (np.sign(v[:-1]) * np.sign(v[1:]) < 0))
    if i.size < 2:
        return math.nan
    w = v[i] / (v[i] - v[i + 1])
    force = m.force[i] + w * (m.force[i + 1] - m.force[i])
    x = m.x[i] + w * (m.x[i + 1] - m.x[i])
    top, bottom = force[x > 0], force[x < 0]
    if not (top.size and bottom.size):
        return math.nan
    return float((np.mean(top) + np.mean(bottom)) / 2)


def with_gas_force(tests: Sequence[TestData]) -> list[TestData]:
    """The tests, each with a gas force: its own measured one; else the median of those
    measured at the other clicks of its gas setting (a measurement at a shut bleed can be
    unusable: run/gas_measure.py), still "measured"; else the reversal estimate of its gas
    setting (module docstring), marked "estimated"."""
    measured: dict[int, list[float]] = {}
    estimates: dict[int, list[float]] = {}
    for t in tests:
        if t.meta.gas_force_n is not None:
            if (t.meta.gas_force_source or MEASURED) == MEASURED:
                measured.setdefault(t.meta.gas_clicks, []).append(t.meta.gas_force_n)
            continue
        est = reversal_estimate(t)
        if math.isfinite(est):
            estimates.setdefault(t.meta.gas_clicks, []).append(est)
    fill = {g: (float(np.median(v)), ESTIMATED) for g, v in estimates.items()}
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
