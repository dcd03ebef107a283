"""The static gas force of a recording's tests, and the damping force with it removed.

Dyno shops read damping force: the force minus the gas force that pushes the rod out at
rest. Click charts, peak-force plots and summaries show it with the gas force removed
(``--raw-force`` shows the force as measured).

**Given.** ``--gas-force-n`` (``report``, ``compare``): the user's value, for every gas
setting or per gas setting; it replaces whatever the recording holds. Source ``given``.

**Measured.** A sweep measures the gas force at mid-stroke at rest at its start and after
each click change (run/gas_measure.py) and stores it with every test: ``gas_force_n``,
``gas_force_source = "measured"``.

**Estimated** (older and imported recordings). At a sine's reversals (x = ±A) the velocity
is zero, so the damping is gone, and the acceleration is ∓ω²A, so inertia terms cancel in
the mean of the two ends. For a gas spring linear over the stroke that mean is its force at
mid-stroke. The isothermal gas spring is slightly convex, so the mean reads high by
``p V0² / (V0² - (A_rod A)²)`` over ``p``: +1.3 N (0.6 %) at 30 mm on the simulated S46.
A closed bleed breaks it: the valves' preload makes the force jump at the reversal
(the simulated S46 at click 0 steps from +820 to -1045 N within one 1 ms sample) and holds
the two ends far apart, so the estimate of a gas setting (the gas force does not depend on
rod clicks) comes from the tests whose two ends are closest: those whose bleed lets the
force relax. Marked ``gas_force_source = "estimated"``.

Every estimate carries its uncertainty (1σ): the scatter of its reversals, and the
**resolution**: the force at a reversal is read between the two samples that straddle it,
so where it jumps between them (a shut bleed) the reading could lie anywhere in that jump,
and the estimate depends on where the samples happen to fall, that is on the sample rate
(the shipped click-0 example gives 230 N at 500 Hz and -291 N thinned to 333 Hz). That
part is each reversal's half-jump as a uniform spread (half-jump / √3); when it exceeds
``RESOLUTION_N`` (or ``RESOLUTION_SHARE`` of the estimate) the estimate is flagged as
depending on the sample rate, with a warning.

**Bounded.** A gas force pushes the rod out, so it is > 0, and the damper spec's charge,
compressed isothermally to the deepest the recording went, bounds it from above (250 N for
the S46's 16 bar at +30 mm). An estimate outside is refused: nothing is removed for that
gas setting, and the note says why and to give the gas force (issue 47.1: the page had
accepted "-121 N estimated", and compare then read the same damper 351 N stiffer).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shockdyno.errors import ConfigError
from shockdyno.model import DamperSpec
from shockdyno.model.composite import ATMOSPHERE_PA, gas_volume
from shockdyno.model.kinematics import velocity
from shockdyno.model.spec import load_spec, spec_used
from shockdyno.record.types import TestData
from shockdyno.units import SI, Units

FloatArray = NDArray[np.float64]

SPREAD_SLACK_N = 20.0  # reversal spreads this close to the closest test's count as alike
RESOLUTION_N = 10.0  # an estimate less resolved than this (1σ) depends on the sample rate
RESOLUTION_SHARE = 0.1  # ... or than this share of itself
SD_FLOOR_N = 0.5  # no test weighs in as if known better than this
MEASURED = "measured"
ESTIMATED = "estimated"
GIVEN = "given"
REFUSED = "refused"
ALL_SETTINGS = -1  # the key of a given gas force that holds for every gas setting


@dataclass(frozen=True)
class Reversals:
    """One test's reversals: the mean force at the top (x > 0) and bottom ones, and the
    1σ of their midpoint from their scatter and from the samples' resolution."""

    top_n: float
    bottom_n: float
    scatter_n: float
    resolution_n: float
    jump_n: float  # the largest mean force change across the samples straddling a reversal
    rate_hz: float

    @property
    def midpoint_n(self) -> float:
        return (self.top_n + self.bottom_n) / 2

    @property
    def spread_n(self) -> float:
        return abs(self.top_n - self.bottom_n)

    @property
    def sd_n(self) -> float:
        return math.hypot(self.scatter_n, self.resolution_n)


def reversals(test: TestData) -> Reversals | None:
    """The reversals of the measured cycles (each force interpolated where the velocity
    crosses zero); None without a top and a bottom one."""
    m = test.measured()
    if m.t.size < 10:
        return None
    v = velocity(m.t, m.x)
    ok = np.isfinite(v[:-1]) & np.isfinite(v[1:])
    # A velocity of exactly zero at a sample is a reversal too: its sign is the next
    # sample's (a product of signs missed it, and one of the four reversals of a shut
    # bleed's test thinned to 333 Hz went uncounted).
    sign = np.sign(v)
    zero = np.flatnonzero(sign[:-1] == 0)
    sign[zero] = sign[zero + 1]
    i = np.flatnonzero(ok & (sign[:-1] * sign[1:] < 0))
    if i.size < 2:
        return None
    w = v[i] / (v[i] - v[i + 1])
    step = m.force[i + 1] - m.force[i]
    force = m.force[i] + w * step
    x = m.x[i] + w * (m.x[i + 1] - m.x[i])
    half = np.abs(step) / 2
    ends = [(force[x > 0], half[x > 0]), (force[x < 0], half[x < 0])]
    if not all(f.size for f, _ in ends):
        return None
    scatter = [float(np.var(f, ddof=1)) / f.size if f.size > 1 else 0.0 for f, _ in ends]
    resolution = [float(np.mean(h)) ** 2 / 3 for _, h in ends]
    return Reversals(
        top_n=float(np.mean(ends[0][0])),
        bottom_n=float(np.mean(ends[1][0])),
        scatter_n=math.sqrt(sum(scatter)) / 2,
        resolution_n=math.sqrt(sum(resolution)) / 2,
        jump_n=2 * max(float(np.mean(h)) for _, h in ends),
        rate_hz=float(1 / np.median(np.diff(m.t))),
    )


def reversal_forces(test: TestData) -> tuple[float, float]:
    """The mean force at the top (x > 0) and at the bottom reversals; NaN without both."""
    r = reversals(test)
    return (r.top_n, r.bottom_n) if r is not None else (math.nan, math.nan)


def reversal_estimate(test: TestData) -> float:
    """The mean of the forces at the top and bottom reversals; NaN without both."""
    top, bottom = reversal_forces(test)
    return (top + bottom) / 2


@dataclass(frozen=True)
class Charge:
    """The largest gas force a spec's charge allows over a stroke, and whence."""

    max_n: float
    what: str  # "sim/ohlins-s46.toml's 16.0 bar charge at +30 mm"


def charge_limit(spec: DamperSpec, stroke_m: float, name: str) -> Charge:
    """The spec's charge compressed isothermally by the rod at `stroke_m` (the deepest a
    recording went): no gas force the damper makes at rest within that stroke is larger."""
    x = np.array([max(stroke_m, 0.0)])
    v0 = spec.gas_volume_m3
    p = spec.gas_pressure_pa * v0 / float(gas_volume(spec, x)[0])
    return Charge(
        max_n=(p - ATMOSPHERE_PA) * spec.rod_area_m2,
        what=(f"{name}'s {spec.gas_pressure_pa / 1e5:.1f} bar charge at {stroke_m * 1e3:+.0f} mm"),
    )


def limit_for(
    tests: Sequence[TestData],
    spec: str | Path | None = None,
    metadata: Mapping[str, str] | None = None,
    fit_spec: DamperSpec | None = None,
) -> Charge | None:
    """The bound of the tests' gas force: the fit's damper (its calibrated charge) when
    given, else the spec named (`--spec`), else the one a simulated recording names, else
    the default spec (as fit and diagnose assume). None when a spec not named by the user
    cannot be read: then only > 0 is checked."""
    deepest = deepest_m(tests)
    if fit_spec is not None:
        return charge_limit(fit_spec, deepest, "the fitted damper")
    named = (metadata or {}).get("damper_spec") or None
    path = spec if spec is not None else named if named and Path(named).is_file() else None
    try:
        return charge_limit(load_spec(path), deepest, spec_used(path)["path"])
    except ConfigError:
        if spec is not None:
            raise
        return None


def deepest_m(tests: Sequence[TestData]) -> float:
    """The deepest compression (largest x) the tests' measured cycles reached."""
    tops = [float(np.max(t.measured().x)) for t in tests if t.measured().x.size]
    return max(tops, default=0.0)


@dataclass(frozen=True)
class GasForce:
    """One gas setting's static gas force: its value (None: none removed), 1σ (NaN when
    not known), where it came from, and what the reader must be told of it."""

    gas_clicks: int
    value_n: float | None
    sd_n: float = math.nan
    source: str = ESTIMATED
    estimate_n: float = math.nan  # a refused estimate's value
    limit: Charge | None = None  # the bound an estimate was checked against
    jump_n: float = math.nan  # set when the estimate depends on the sample rate
    rate_hz: float = math.nan

    @property
    def removed(self) -> bool:
        return self.value_n is not None

    @property
    def rate_dependent(self) -> bool:
        return math.isfinite(self.jump_n)

    def amount(self, units: Units = SI) -> str:
        """'231 ± 3 N' (the ± only when known)."""
        value = self.value_n if self.value_n is not None else self.estimate_n
        text = f"{units.force(value):.0f}"
        if math.isfinite(self.sd_n) and self.source in (ESTIMATED, REFUSED):
            text += f" ± {units.force(self.sd_n):.0f}"
        return f"{text} {units.force_label}"

    def refusal(self, units: Units = SI) -> str:
        """Why an estimate was not used (empty when it was)."""
        if self.source != REFUSED:
            return ""
        most = (
            f" and {self.limit.what} allows at most {units.force(self.limit.max_n):.0f} "
            f"{units.force_label}"
            if self.limit is not None
            else ""
        )
        return (
            f"the estimate at gas clicks {self.gas_clicks}, {self.amount(units)}, is no gas "
            f"force (a gas force pushes the rod out, > 0{most}): not removed; give the "
            "damper's own with --gas-force-n"
        )

    def warning(self, units: Units = SI) -> str:
        """The sample-rate warning of an estimate (empty when it has none)."""
        if not self.rate_dependent:
            return ""
        return (
            f"the gas force estimated at gas clicks {self.gas_clicks} depends on the sample "
            f"rate: at {self.rate_hz:.0f} Hz the force changes by up to "
            f"{units.force(self.jump_n):.0f} {units.force_label} between the samples either "
            "side of a reversal (a shut bleed's valve, or the friction, turns between them), "
            f"so where they fall decides the estimate ({self.amount(units)}); give the gas "
            "force with --gas-force-n, or record faster"
        )


GasForces = dict[int, GasForce]


def _estimate(gas_clicks: int, found: Sequence[Reversals], limit: Charge | None) -> GasForce:
    """A gas setting's estimate (module docstring): of the tests whose two ends are
    closest (within 1.5x the closest spread, plus 20 N), the mean weighted by each one's
    1/σ², its σ widened when they disagree beyond their own. A plain median was pulled to
    132 N (against 231 N) by a sweep half of whose tests had a shut bleed; a shut-bleed
    test whose ends happen to lie close weighs nothing beside the relaxed ones."""
    closest = min(r.spread_n for r in found)
    kept = [r for r in found if r.spread_n <= 1.5 * closest + SPREAD_SLACK_N]
    weight = np.array([1 / max(r.sd_n, SD_FLOOR_N) ** 2 for r in kept])
    mids = np.array([r.midpoint_n for r in kept])
    value = float(np.sum(weight * mids) / np.sum(weight))
    sd = math.sqrt(1 / float(np.sum(weight)))
    if len(kept) > 1:  # tests that disagree beyond their own σ widen it (Birge ratio)
        chi2 = float(np.sum(weight * (mids - value) ** 2)) / (len(kept) - 1)
        sd *= math.sqrt(max(chi2, 1.0))
    resolution = math.sqrt(
        float(np.sum(weight * np.array([r.resolution_n for r in kept]) ** 2) / np.sum(weight))
    )
    dependent = resolution > max(RESOLUTION_N, RESOLUTION_SHARE * abs(value))
    worst = max(kept, key=lambda r: r.resolution_n)
    shown = {"jump_n": worst.jump_n, "rate_hz": worst.rate_hz} if dependent else {}
    if value <= 0 or (limit is not None and value > limit.max_n):
        return GasForce(gas_clicks, None, sd, REFUSED, value, limit, **shown)
    return GasForce(gas_clicks, round(value, 2), sd, ESTIMATED, limit=limit, **shown)


def gas_forces(
    tests: Sequence[TestData],
    given: Mapping[int, float] | None = None,
    limit: Charge | None = None,
) -> GasForces:
    """Each gas setting's gas force: given (`given`, by gas clicks or ALL_SETTINGS); else
    the median of those measured at its clicks (a measurement at a shut bleed can be
    unusable: run/gas_measure.py), lent to its other clicks; else a stored estimate (an
    imported file's); else the reversal estimate checked against `limit`."""
    given = dict(given or {})
    measured: dict[int, list[float]] = {}
    stored: dict[int, list[float]] = {}
    found: dict[int, list[Reversals]] = {}
    for t in tests:
        g, value = t.meta.gas_clicks, t.meta.gas_force_n
        if value is not None and math.isfinite(value):
            kind = measured if (t.meta.gas_force_source or MEASURED) == MEASURED else stored
            kind.setdefault(g, []).append(value)
        elif (r := reversals(t)) is not None:
            found.setdefault(g, []).append(r)
    out: GasForces = {}
    for g in sorted({t.meta.gas_clicks for t in tests}):
        if g in given or ALL_SETTINGS in given:
            out[g] = GasForce(g, given.get(g, given.get(ALL_SETTINGS)), source=GIVEN)
        elif g in measured:
            out[g] = GasForce(g, float(np.median(measured[g])), source=MEASURED)
        elif g in stored:
            out[g] = GasForce(g, float(np.median(stored[g])), source=ESTIMATED)
        elif g in found:
            out[g] = _estimate(g, found[g], limit)
    return out


def apply(tests: Sequence[TestData], forces: GasForces) -> list[TestData]:
    """The tests, each with its setting's gas force in its meta (a given one replaces what
    it held; a refused estimate leaves it without)."""
    out = []
    for t in tests:
        f = forces.get(t.meta.gas_clicks)
        keep = t.meta.gas_force_n is not None and (f is None or f.source != GIVEN)
        if f is not None and not keep:
            value = None if f.value_n is None else round(f.value_n, 2)
            source = f.source if f.value_n is not None else None
            t = replace(t, meta=replace(t.meta, gas_force_n=value, gas_force_source=source))
        out.append(t)
    return out


def with_gas_force(
    tests: Sequence[TestData],
    given: Mapping[int, float] | None = None,
    limit: Charge | None = None,
) -> list[TestData]:
    """The tests with their gas force (:func:`gas_forces`, :func:`apply`)."""
    return apply(tests, gas_forces(tests, given, limit))


def gas_force_n(test: TestData) -> float:
    """The test's gas force (0 when neither stored nor estimated: nothing is removed)."""
    g = test.meta.gas_force_n
    return float(g) if g is not None and math.isfinite(g) else 0.0


def damping_force(test: TestData) -> FloatArray:
    """Force minus the test's gas force (call :func:`with_gas_force` first to estimate it)."""
    return np.asarray(test.force - gas_force_n(test), dtype=float)


def remove_gas(tests: Sequence[TestData]) -> list[TestData]:
    """The tests with force = damping force (their gas force, as :func:`with_gas_force`
    left it; a test without one keeps its force)."""
    return [replace(t, force=damping_force(t)) for t in tests]


WHERE = {
    MEASURED: "measured at mid-stroke at rest",
    ESTIMATED: "estimated from the sine's reversals",
    GIVEN: "given (--gas-force-n)",
}


def describe_forces(forces: GasForces, units: Units = SI) -> str:
    """For captions and headers: 'gas force removed: 231 ± 2 N estimated from the sine's
    reversals', and any gas setting whose estimate was refused."""
    parts = []
    for source, where in WHERE.items():
        group = [f for f in forces.values() if f.source == source and f.value_n is not None]
        if not group:
            continue
        values = [units.force(f.value_n) for f in group if f.value_n is not None]
        lo, hi = min(values), max(values)
        amount = f"{lo:.0f}" if round(lo) == round(hi) else f"{lo:.0f}-{hi:.0f}"
        sds = [units.force(f.sd_n) for f in group if math.isfinite(f.sd_n)]
        spread = f" ± {max(sds):.0f}" if sds and source == ESTIMATED else ""
        parts.append(f"{amount}{spread} {units.force_label} {where}")
    refused = [f.refusal(units) for f in forces.values() if f.source == REFUSED]
    if not parts:
        if refused:
            return "gas force not removed: " + "; ".join(refused)
        return "gas force not removed: none measured and none could be estimated"
    return "gas force removed: " + "; ".join(parts + refused)


def warnings(forces: GasForces, units: Units = SI) -> list[str]:
    """What the reader must be told beside the numbers: refusals, sample-rate dependence."""
    out = [f.refusal(units) for f in forces.values() if f.source == REFUSED]
    return out + [f.warning(units) for f in forces.values() if f.rate_dependent]


def describe(tests: Sequence[TestData], units: Units = SI) -> str:
    """:func:`describe_forces` of what the tests hold (after :func:`with_gas_force`)."""
    return describe_forces(gas_forces(tests), units)


def parse_given(text: str, flag: str = "--gas-force-n") -> dict[int, float]:
    """`231` (every gas setting) or `0:231,5:260` (N by gas clicks), each > 0."""
    out: dict[int, float] = {}
    for item in (p.strip() for p in text.split(",")):
        key, sep, value = item.rpartition(":")
        try:
            gas = int(key) if sep else ALL_SETTINGS
            force = float(value)
        except ValueError:
            raise ConfigError(
                f"{flag} {text!r}: give newtons, e.g. 231, or per gas setting, e.g. 0:231,5:260"
            ) from None
        if not (math.isfinite(force) and force > 0):
            raise ConfigError(f"{flag}: a gas force pushes the rod out, so is > 0 N; got {value}")
        if sep and gas < 0:
            raise ConfigError(f"{flag}: gas clicks are 0 or more, got {key}")
        out[gas] = force
    return out
