"""Click charts: force at standard velocities per click, measured and modelled.

This is the view dampers are tuned with: for each adjuster setting, the force at 25, 50,
100, 150, 200 and 300 mm/s in compression and in rebound.

**Measured.** A test's velocity passes each standard velocity twice per cycle in each
direction (speeding up and slowing down, at different strokes). The force is read at
every such crossing of the measured cycles (linear interpolation between the two samples
that straddle it) and averaged: the branch of that direction at that velocity, not the
peak. A click's value averages the tests (frequencies) whose branch reaches the velocity.
When none does, the value is extrapolated from the test that gets closest, by a straight
line through the top 30 % of its branch, and flagged ``extrapolated``.

**Constant-velocity tests** (triangle, trapezoid: report/constant_velocity.py) give one
point per direction at their speed: the mean force over the constant-velocity part of
their strokes. At a standard velocity within ``CV_MATCH`` of a test's speed that mean is
the value (the averaged points' count in ``n_tests``); between two tests' speeds of one
setting the value is read on the straight line between their points (before a sine's
extrapolation, after a sine's crossing); beyond them, extrapolated through the two nearest
and flagged. A constant-velocity test's reversals are not read as a sine's branch.

**Model.** The fitted model (``FitResult.model()``, as a car carries it: its damper
terms, no sensor terms, lags at their steady state) with the click's areas
(``FitResult.areas``) at mid-stroke (x = 0) and zero acceleration: the damper's steady
characteristic. It differs from the measured value by what the branch average
carries and the characteristic does not (gas spring over the stroke, inertia, hysteresis).

**Gas force removed** (the default): measured values are read from the damping force,
force minus each test's gas force (measured at mid-stroke, else estimated: report/gas.py),
and model values have the model's own force at rest at mid-stroke removed, so both show
damping alone and agree. ``raw_force=True`` keeps the force as measured (gas included).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from shockdyno import units as units_mod
from shockdyno.errors import FitError
from shockdyno.model import DamperSpec, damper_force
from shockdyno.model.kinematics import velocity
from shockdyno.model.quarter_car import quasi_static_force
from shockdyno.record.types import TestData
from shockdyno.report import gas as gas_force
from shockdyno.report.constant_velocity import cv_points, is_constant_velocity
from shockdyno.units import SI, Units

if TYPE_CHECKING:  # only its methods are called: no import of the fit package at run time
    from shockdyno.fit.result import FitResult

FloatArray = NDArray[np.float64]

STANDARD_VELOCITIES_M_S = SI.standard_velocities_m_s  # imperial: units.IMPERIAL's
EXTRAPOLATION_SPAN = 0.3  # share of the branch's top speed the straight line is fitted over
MIN_BRANCH_SAMPLES = 5

Setting = tuple[int, int]  # (clicks, gas clicks)


@dataclass(frozen=True)
class Reading:
    """A force at one signed velocity (+ compression) for one click setting."""

    force_n: float
    extrapolated: bool = False
    n_tests: int = 0  # tests whose branch reaches the velocity (0 when extrapolated)


@dataclass(frozen=True)
class ClickChart:
    velocities_m_s: tuple[float, ...]  # signed: rebound negative, compression positive
    settings: list[Setting]
    measured: dict[Setting, dict[float, Reading]]
    model: dict[Setting, dict[float, float]]  # empty without a fit
    model_curve: dict[int, dict[float, float]]  # every click of the fit's range (trend)
    # Gas force removed from the values above (N, per setting; empty when raw_force):
    gas_force_n: dict[Setting, float] = field(default_factory=dict)  # measured/estimated
    model_gas_force_n: dict[Setting, float] = field(default_factory=dict)  # model at rest
    raw_force: bool = True
    gas_note: str = ""  # 'gas force removed: 231 N measured at mid-stroke at rest'

    @property
    def any_extrapolated(self) -> bool:
        return any(r.extrapolated for row in self.measured.values() for r in row.values())


def signed_velocities(speeds: Sequence[float] = STANDARD_VELOCITIES_M_S) -> tuple[float, ...]:
    """Rebound (fastest first) then compression (slowest first)."""
    return units_mod.signed_velocities(speeds)  # the order fit/forces.py saves too


def branch_force(v: FloatArray, force: FloatArray, target_m_s: float) -> Reading:
    """The force of one test's branch at a signed velocity (module docstring)."""
    sign = 1.0 if target_m_s > 0 else -1.0
    speed = sign * v  # > 0 on this direction's branch
    ok = np.isfinite(speed) & np.isfinite(force)
    speed, f = speed[ok], force[ok]
    on_branch = speed > 0
    if np.count_nonzero(on_branch) < MIN_BRANCH_SAMPLES:
        return Reading(math.nan)
    s = speed - abs(target_m_s)
    # A crossing between samples i and i+1, in either direction of travel.
    i = np.flatnonzero((s[:-1] <= 0) & (s[1:] > 0) | (s[:-1] > 0) & (s[1:] <= 0))
    if i.size:
        w = s[i] / (s[i] - s[i + 1])
        return Reading(float(np.mean(f[i] + w * (f[i + 1] - f[i]))), False, 1)
    top = float(np.max(speed))
    near = on_branch & (speed >= (1 - EXTRAPOLATION_SPAN) * top)
    if np.count_nonzero(near) < MIN_BRANCH_SAMPLES or np.ptp(speed[near]) <= 0:
        return Reading(math.nan)
    slope, intercept = np.polyfit(speed[near], f[near], 1)
    return Reading(float(intercept + slope * abs(target_m_s)), True, 0)


def _test_readings(test: TestData, targets: Sequence[float]) -> tuple[dict[float, Reading], float]:
    m = test.measured()
    v = velocity(m.t, m.x)
    top = float(np.nanmax(np.abs(v))) if v.size and np.any(np.isfinite(v)) else 0.0
    return {t: branch_force(v, m.force, t) for t in targets}, top


CV_MATCH = 0.02  # a constant-velocity test within 2 % of a standard velocity reads it


def measured_chart(
    tests: Sequence[TestData], targets: Sequence[float]
) -> dict[Setting, dict[float, Reading]]:
    """Per click setting and signed velocity: the mean over tests that reach it, else the
    extrapolation of the test closest to it (constant-velocity tests: the module's
    docstring). Complete tests only."""
    complete = [t for t in tests if t.meta.status == "complete"]
    cv = [t for t in complete if is_constant_velocity(t)]
    sines = _branch_chart([t for t in complete if not is_constant_velocity(t)], targets)
    if not cv:
        return sines
    points: dict[Setting, list[tuple[float, float]]] = {}
    for test in cv:
        pair = cv_points(test)
        if pair is not None:
            key = (test.meta.clicks, test.meta.gas_clicks)
            points.setdefault(key, []).extend((p.velocity_m_s, p.force_n) for p in pair)
    out: dict[Setting, dict[float, Reading]] = {}
    for key in sorted(set(sines) | set(points)):
        sine_row = sines.get(key, {})
        row: dict[float, Reading] = {}
        for t in targets:
            exact, between, beyond = _cv_reading(points.get(key, []), t)
            s = sine_row.get(t, Reading(math.nan))
            inside = math.isfinite(s.force_n) and not s.extrapolated
            order = [exact, s if inside else None, between, s, beyond]
            row[t] = next((r for r in order if r is not None and math.isfinite(r.force_n)),
                          Reading(math.nan))  # fmt: skip
        out[key] = row
    return out


def _cv_reading(
    points: list[tuple[float, float]], target: float
) -> tuple[Reading | None, Reading | None, Reading | None]:
    """(the mean of the points at the target's speed, the line between the two around it,
    the line through the two nearest beyond them) in the target's direction."""
    side = sorted((abs(v), f) for v, f in points if v * target > 0)
    speed = abs(target)
    at = [f for v, f in side if abs(v / speed - 1) <= CV_MATCH]
    if at:
        return Reading(float(np.mean(at)), False, len(at)), None, None
    below = [p for p in side if p[0] < speed]
    above = [p for p in side if p[0] > speed]
    if below and above:
        (v0, f0), (v1, f1) = below[-1], above[0]
        return None, Reading(f0 + (f1 - f0) * (speed - v0) / (v1 - v0), False, 2), None
    near = below[-2:] if below else above[:2]
    if len(near) < 2 or near[0][0] == near[1][0]:
        return None, None, None
    (v0, f0), (v1, f1) = near
    return None, None, Reading(f0 + (f1 - f0) * (speed - v0) / (v1 - v0), True, 0)


def _branch_chart(
    tests: Sequence[TestData], targets: Sequence[float]
) -> dict[Setting, dict[float, Reading]]:
    """measured_chart of tests read on their branches (sines, imported motion)."""
    per_setting: dict[Setting, list[tuple[dict[float, Reading], float]]] = {}
    for test in tests:
        if test.meta.status != "complete" or test.t.size < 3 * MIN_BRANCH_SAMPLES:
            continue
        key = (test.meta.clicks, test.meta.gas_clicks)
        per_setting.setdefault(key, []).append(_test_readings(test, targets))
    out: dict[Setting, dict[float, Reading]] = {}
    for key, readings in sorted(per_setting.items()):
        row: dict[float, Reading] = {}
        for t in targets:
            inside = [r[t].force_n for r, _ in readings if not r[t].extrapolated]
            inside = [f for f in inside if math.isfinite(f)]
            if inside:
                row[t] = Reading(float(np.mean(inside)), False, len(inside))
                continue
            # The test with the fastest branch in this direction is the shortest reach.
            outside = [r[t] for r, _ in sorted(readings, key=lambda p: -p[1])]
            row[t] = next((r for r in outside if math.isfinite(r.force_n)), Reading(math.nan))
        out[key] = row
    return out


def model_forces(
    fit: FitResult, clicks: int, targets: Sequence[float], gas_clicks: int | None = None
) -> dict[float, float]:
    """The fitted model at mid-stroke, zero acceleration, at each signed velocity: as the
    fit saved it (`fit.saved`, fit/forces.py), else computed."""
    a_bc, a_bt = fit.areas(clicks, gas_clicks=gas_clicks)
    force = fit.saved.at(a_bc, a_bt, targets) if fit.saved is not None else None
    if force is None:
        v = np.asarray(targets, dtype=float)
        zeros = np.zeros_like(v)
        force = quasi_static_force(fit.model().vehicle(), zeros, v, zeros, a_bc, a_bt)
    return {t: float(f) for t, f in zip(targets, force, strict=True)}


def static_force_n(fit: FitResult) -> float:
    """The model's force at rest at mid-stroke: the gas force on the rod."""
    first = fit.clicks[0] if fit.clicks else None
    return model_static_force_n(fit, first.clicks if first else 0, first.gas_clicks if first else 0)


def model_static_force_n(fit: FitResult, clicks: int, gas_clicks: int | None = None) -> float:
    """The fitted model's force at rest at mid-stroke with this click's areas: its gas force."""
    return model_forces(fit, clicks, (0.0,), gas_clicks)[0.0]


def _minus(values: dict[float, float], amount: float) -> dict[float, float]:
    return {v: f - amount for v, f in values.items()}


def click_chart(
    tests: Sequence[TestData],
    fit: FitResult | None = None,
    speeds_m_s: Sequence[float] = STANDARD_VELOCITIES_M_S,
    *,
    raw_force: bool = False,
    gas: gas_force.GasForces | None = None,
) -> ClickChart:
    """The chart, gas force removed from measured and model values unless `raw_force`:
    each gas setting's of `gas` (as the caller found it: given, measured, estimated), else
    as report/gas.py finds it in the tests."""
    targets = signed_velocities(speeds_m_s)
    removed: dict[Setting, float] = {}
    model_gas: dict[Setting, float] = {}
    note = ""
    if not raw_force:
        forces = gas if gas is not None else gas_force.gas_forces(tests)
        tests = gas_force.apply(tests, forces)
        note = gas_force.describe_forces(forces)
        per_setting: dict[Setting, list[float]] = {}
        for t in tests:
            if t.meta.gas_force_n is not None:
                key = (t.meta.clicks, t.meta.gas_clicks)
                per_setting.setdefault(key, []).append(t.meta.gas_force_n)
        removed = {k: float(np.mean(v)) for k, v in per_setting.items()}
        tests = gas_force.remove_gas(tests)
    measured = measured_chart(tests, targets)
    model: dict[Setting, dict[float, float]] = {}
    curve: dict[int, dict[float, float]] = {}
    if fit is not None and fit.clicks:
        for c in fit.clicks:
            key = (c.clicks, c.gas_clicks)
            model[key] = model_forces(fit, c.clicks, targets, c.gas_clicks)
            if not raw_force:
                model_gas[key] = model_static_force_n(fit, c.clicks, c.gas_clicks)
                model[key] = _minus(model[key], model_gas[key])
        main_gas = fit.main_gas_clicks()  # the trend's curve is at the main gas setting
        fitted = sorted({c.clicks for c in fit.clicks if c.gas_clicks == main_gas})
        for n in range(fitted[0], fitted[-1] + 1):
            try:
                curve[n] = model_forces(fit, n, targets)
                if not raw_force:
                    curve[n] = _minus(curve[n], model_static_force_n(fit, n))
            except FitError:  # no trend to interpolate between fitted clicks
                continue
    settings = sorted(set(measured) | set(model))
    return ClickChart(
        targets, settings, measured, model, curve, removed, model_gas, raw_force, note
    )


def velocity_label(v_m_s: float, units: Units = SI) -> str:
    word = "comp" if v_m_s > 0 else "reb"
    return f"{word} {units.velocity(abs(v_m_s)):.3g}"


def table_rows(
    chart: ClickChart, source: str, units: Units = SI
) -> tuple[list[str], list[list[str]]]:
    """(header, rows) for the page: one row per setting, forces in ``units``; '*' =
    extrapolated. Velocities in the header are ``units``' (mm/s or in/s)."""
    gas = len({g for _, g in chart.settings}) > 1
    header = [
        "clicks",
        *(["gas"] if gas else []),
        *(velocity_label(v, units) for v in chart.velocities_m_s),
    ]
    rows = []
    for key in chart.settings:
        cells = [str(key[0]), *([str(key[1])] if gas else [])]
        if source == "measured":
            row = chart.measured.get(key)
            if row is None:
                continue
            for t in chart.velocities_m_s:
                r = row[t]
                f = units.force(r.force_n)
                text = "–" if not math.isfinite(f) else f"{f:.0f}"
                cells.append(text + ("*" if r.extrapolated and math.isfinite(r.force_n) else ""))
        else:
            mrow = chart.model.get(key)
            if mrow is None:
                continue
            cells += [f"{units.force(mrow[t]):.0f}" for t in chart.velocities_m_s]
        rows.append(cells)
    return header, rows


CSV_HEADER = [
    "clicks",
    "gas_clicks",
    "velocity_m_s",
    "source",
    "force_n",
    "extrapolated",
    "n_tests",
    "gas_removed",  # 1: force_n is damping force (gas force removed); 0: raw force
    "gas_force_n",  # the gas force removed from this row (empty when raw)
]


def csv_header(units: Units = SI) -> list[str]:
    """The CSV's columns; velocity and force name their units (SI: the columns of old)."""
    if not units.imperial:
        return CSV_HEADER
    return [
        "clicks",
        "gas_clicks",
        "velocity_in_s",
        "source",
        "force_lbf",
        "extrapolated",
        "n_tests",
        "gas_removed",
        "gas_force_lbf",
    ]


def to_csv(chart: ClickChart, units: Units = SI) -> str:
    """Long format, one row per setting, velocity and source (measured, model); velocity
    and force in ``units`` (the header says which); each row says whether its force is
    damping force (gas removed) and the gas force it removed."""
    text = io.StringIO()
    w = csv.writer(text, lineterminator="\n")
    w.writerow(csv_header(units))
    removed = int(not chart.raw_force)

    # SI keeps its m/s column; imperial's in/s at the 1, 2, 3 ... of its chart.
    def speed(t: float) -> str:
        return f"{units.velocity(t):.4g}" if units.imperial else f"{t:g}"

    def gas(values: dict[Setting, float], key: Setting) -> str:
        g = values.get(key)
        return "" if chart.raw_force or g is None else f"{units.force(g):.2f}"

    for key in chart.settings:
        for t in chart.velocities_m_s:
            r = chart.measured.get(key, {}).get(t)
            if r is not None:
                f = units.force(r.force_n)
                force = f"{f:.2f}" if math.isfinite(f) else ""
                w.writerow([*key, speed(t), "measured", force, int(r.extrapolated), r.n_tests,
                            removed, gas(chart.gas_force_n, key)])  # fmt: skip
            mf = chart.model.get(key, {}).get(t)
            if mf is not None:
                w.writerow([*key, speed(t), "model", f"{units.force(mf):.2f}", 0, "", removed,
                            gas(chart.model_gas_force_n, key)])  # fmt: skip
    return text.getvalue()


def spec_static_force_n(spec: DamperSpec) -> float:
    """A spec's force at rest at mid-stroke (its own bleed areas at 0 clicks)."""
    a_bc, a_bt = spec.bleed_areas(0, 0)
    return float(np.asarray(damper_force(spec, 0.0, 0.0, 0.0, a_bc, a_bt)).reshape(-1)[0])
