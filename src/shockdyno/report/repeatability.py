"""Repeatability: how much a test's cycles, and a click's tests, scatter; and drift.

A number on a click chart is only as good as its scatter: a 10 N change means nothing if
the cycles of one test differ by 20 N. Everything here comes from the recording itself.

**Cycles.** A test's measured window is cut into its cycles (the recorded cycle starts
when the sweep stored them, else every 1/f from the window's start). Per cycle: the peak
compression force (max F), the peak rebound force (min F), and the click-chart reading at
each standard velocity, that is ``clickchart.branch_force`` on that cycle alone (the
mean of the cycle's crossings of the velocity; a cycle that does not cross it has no
reading, never an extrapolated one). The chart's measured value of a test is the mean of
its crossings, so of these per-cycle readings.

**Scatter of a chart value.** For one click setting and velocity:

- cycle-to-cycle SD: the pooled within-test SD of the per-cycle readings;
- test-to-test SD: the SD of the test means, when two or more tests of the setting reach
  the velocity (other frequencies, or repeated tests);
- the SD of the chart value (a mean over ``k`` tests of ``n`` cycles in all): the larger
  of ``test SD / √k`` and ``cycle SD / √n``. The test-to-test SD already contains the
  cycle noise of each test mean; with a single test only the cycle term is known.

**Bands on the plots.** ±2 SD of the per-cycle values (peak forces, chart readings):
the range about 95 % of single cycles fall in, not the uncertainty of the mean.

**Drift.** A straight line through a test's per-cycle peak force against cycle number.
It is a drift when the slope is significant against the scatter about the line
(|t| > ``DRIFT_T``, at least ``DRIFT_MIN_CYCLES`` cycles) and the change over the test
is at least ``DRIFT_MIN_SHARE`` of the peak force (smaller trends are real but do not
matter on a click chart).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from shockdyno.model.kinematics import velocity
from shockdyno.record.types import TestData
from shockdyno.report import clickchart

FloatArray = NDArray[np.float64]
Setting = clickchart.Setting

BAND_SD = 2.0  # bands on the plots: ± this many SD of single cycles
DRIFT_T = 4.0  # |slope / SE(slope)| beyond which a trend is not the cycles' scatter
DRIFT_MIN_CYCLES = 4
DRIFT_MIN_SHARE = 0.02  # change over the test, share of the mean peak force
DRIFT_CAUSES = (
    "oil warming (temperature), gas charge changing (gas), or a loosening mount or "
    "rod-end (growing free play)"
)


@dataclass(frozen=True)
class TestCycles:
    """Per-cycle values of one test (forces in N, signed; readings keyed by signed velocity)."""

    __test__ = False  # not a pytest test class, despite the name

    index: int
    clicks: int
    gas_clicks: int
    frequency_hz: float
    peak_compression_n: FloatArray
    peak_rebound_n: FloatArray
    readings: dict[float, FloatArray] = field(default_factory=dict)  # NaN: no crossing

    @property
    def setting(self) -> Setting:
        return (self.clicks, self.gas_clicks)

    @property
    def n_cycles(self) -> int:
        return int(self.peak_compression_n.size)


@dataclass(frozen=True)
class Scatter:
    """The scatter of one click-chart value (see the module docstring)."""

    mean_n: float
    cycle_sd_n: float  # pooled within-test SD of single cycles (nan: < 2 cycles)
    test_sd_n: float  # SD of the test means (nan: < 2 tests)
    n_cycles: int
    n_tests: int

    @property
    def sd_of_mean_n(self) -> float:
        """SD of the chart value: the larger of the test and the cycle estimate."""
        terms = []
        if math.isfinite(self.test_sd_n) and self.n_tests >= 2:
            terms.append(self.test_sd_n / math.sqrt(self.n_tests))
        if math.isfinite(self.cycle_sd_n) and self.n_cycles >= 2:
            terms.append(self.cycle_sd_n / math.sqrt(self.n_cycles))
        return max(terms) if terms else math.nan


@dataclass(frozen=True)
class Drift:
    """A test whose per-cycle peak force trends over its cycles."""

    index: int
    clicks: int
    gas_clicks: int
    frequency_hz: float
    direction: str  # "compression" | "rebound"
    first_n: float  # the line's value at the first and last cycle
    last_n: float
    n_cycles: int
    t_value: float
    cycle_sd_n: float  # scatter about the line

    @property
    def change_n(self) -> float:
        return self.last_n - self.first_n

    @property
    def change_share(self) -> float:
        mean = 0.5 * (abs(self.first_n) + abs(self.last_n))
        return abs(self.change_n) / mean if mean > 0 else math.inf

    def text(self) -> str:
        grows = abs(self.last_n) > abs(self.first_n)
        return (
            f"test {self.index} (clicks {self.clicks}, gas {self.gas_clicks}, "
            f"{self.frequency_hz:g} Hz): peak {self.direction} force "
            f"{'grows' if grows else 'falls'} from {self.first_n:.0f} to {self.last_n:.0f} N "
            f"over {self.n_cycles} cycles ({100 * self.change_share:.1f} %, "
            f"{abs(self.t_value):.0f}x its slope's SD; cycle scatter {self.cycle_sd_n:.1f} N): "
            f"likely {DRIFT_CAUSES}"
        )


def cycle_bounds(test: TestData) -> list[tuple[float, float]]:
    """(start, end) times of the measured cycles: recorded starts, else every 1/f."""
    meta = test.meta
    if meta.motion != "sine" or not meta.frequency_hz > 0 or test.t.size < 2:
        return []
    lo, hi = meta.measured_start_s, meta.measured_end_s
    if lo is None or hi is None:  # no window recorded: the whole record is measured
        lo, hi = float(test.t[0]), float(test.t[-1]) + 1.0 / meta.sample_rate_hz
    starts = [s for s in meta.cycle_start_s if lo - 1e-9 <= s < hi - 1e-9]
    if len(starts) >= 1:
        ends = [*starts[1:], hi]
        return list(zip(starts, ends, strict=True))
    period = 1.0 / meta.frequency_hz
    n = math.floor((hi - lo) / period + 1e-6)  # whole cycles only
    return [(lo + k * period, lo + (k + 1) * period) for k in range(n)]


def test_cycles(test: TestData, targets: Sequence[float]) -> TestCycles | None:
    """Per-cycle peaks and readings of one test; None without whole cycles."""
    bounds = cycle_bounds(test)
    m = test.measured()
    if len(bounds) < 1 or m.t.size < 3 * clickchart.MIN_BRANCH_SAMPLES:
        return None
    v = velocity(m.t, m.x)
    comp, reb = [], []
    readings: dict[float, list[float]] = {t: [] for t in targets}
    for lo, hi in bounds:
        # One sample past the cycle's end: a crossing between its last sample and the
        # next cycle's first belongs to this cycle, so none is lost and none counted twice.
        i0, i1 = np.searchsorted(m.t, [lo, hi])
        sl = slice(int(i0), min(int(i1) + 1, m.t.size))
        f = m.force[sl]
        if f.size < clickchart.MIN_BRANCH_SAMPLES:
            continue
        comp.append(float(np.max(f)))
        reb.append(float(np.min(f)))
        for t in targets:
            r = clickchart.branch_force(v[sl], f, t)
            readings[t].append(math.nan if r.extrapolated else r.force_n)
    if not comp:
        return None
    meta = test.meta
    return TestCycles(
        meta.index,
        meta.clicks,
        meta.gas_clicks,
        meta.frequency_hz,
        np.asarray(comp),
        np.asarray(reb),
        {t: np.asarray(r, dtype=float) for t, r in readings.items()},
    )


def sweep_cycles(
    tests: Sequence[TestData], speeds_m_s: Sequence[float] = clickchart.STANDARD_VELOCITIES_M_S
) -> list[TestCycles]:
    """Per-cycle values of the complete tests (the ones a click chart reads)."""
    targets = clickchart.signed_velocities(speeds_m_s)
    out = []
    for test in tests:
        if test.meta.status != "complete":
            continue
        cycles = test_cycles(test, targets)
        if cycles is not None:
            out.append(cycles)
    return out


def _sd(values: FloatArray) -> float:
    values = values[np.isfinite(values)]
    return float(np.std(values, ddof=1)) if values.size >= 2 else math.nan


def band_sd(values: FloatArray) -> float:
    """SD of single cycles (nan with fewer than two)."""
    return _sd(np.asarray(values, dtype=float))


def scatter_of(cycles: Sequence[TestCycles], target: float) -> Scatter:
    """The scatter of one setting's chart value at one signed velocity."""
    per_test = [c.readings[target][np.isfinite(c.readings[target])] for c in cycles]
    per_test = [r for r in per_test if r.size]
    if not per_test:
        return Scatter(math.nan, math.nan, math.nan, 0, 0)
    means = np.array([float(np.mean(r)) for r in per_test])
    n = sum(r.size for r in per_test)
    dof = n - len(per_test)
    ss = sum(float(np.sum((r - np.mean(r)) ** 2)) for r in per_test)
    cycle_sd = math.sqrt(ss / dof) if dof > 0 else math.nan
    return Scatter(float(np.mean(means)), cycle_sd, _sd(means), n, len(per_test))


def chart_scatter(
    cycles: Sequence[TestCycles], targets: Sequence[float]
) -> dict[Setting, dict[float, Scatter]]:
    """Per click setting and signed velocity: the scatter of the measured chart value."""
    by_setting: dict[Setting, list[TestCycles]] = {}
    for c in cycles:
        by_setting.setdefault(c.setting, []).append(c)
    return {
        key: {t: scatter_of(group, t) for t in targets} for key, group in sorted(by_setting.items())
    }


def _trend(peaks: FloatArray) -> tuple[float, float, float, float] | None:
    """(first, last, t, residual SD) of a straight line through the per-cycle peaks."""
    n = peaks.size
    if n < DRIFT_MIN_CYCLES or not np.all(np.isfinite(peaks)):
        return None
    k = np.arange(n, dtype=float)
    slope, intercept = np.polyfit(k, peaks, 1)
    resid = peaks - (intercept + slope * k)
    s = math.sqrt(float(np.sum(resid**2)) / (n - 2))
    sxx = float(np.sum((k - k.mean()) ** 2))
    se = s / math.sqrt(sxx)
    t = slope / se if se > 0 else (math.inf if slope else 0.0)
    return float(intercept), float(intercept + slope * (n - 1)), float(t), s


def drifts(cycles: Sequence[TestCycles]) -> list[Drift]:
    """Tests whose peak compression or rebound force drifts (module docstring's rule)."""
    out = []
    for c in cycles:
        for direction, peaks in (
            ("compression", c.peak_compression_n),
            ("rebound", c.peak_rebound_n),
        ):
            line = _trend(peaks)
            if line is None:
                continue
            first, last, t, s = line
            d = Drift(
                c.index, c.clicks, c.gas_clicks, c.frequency_hz, direction, first, last,
                c.n_cycles, t, s,
            )  # fmt: skip
            if abs(t) > DRIFT_T and d.change_share >= DRIFT_MIN_SHARE:
                out.append(d)
    return out


def peak_band(cycles: Sequence[TestCycles]) -> dict[int, tuple[float, float]]:
    """Per test index: ± half-width (N) of the band of its per-cycle peak forces."""
    return {
        c.index: (BAND_SD * band_sd(c.peak_compression_n), BAND_SD * band_sd(c.peak_rebound_n))
        for c in cycles
    }


def chart_band(
    scatter: dict[Setting, dict[float, Scatter]],
) -> dict[Setting, dict[float, float]]:
    """Per setting and signed velocity: ± half-width (N) of the band of single cycles."""
    return {
        key: {t: BAND_SD * s.cycle_sd_n for t, s in row.items()} for key, row in scatter.items()
    }


def widest(band: dict[Setting, dict[float, float]]) -> float:
    """The widest half-width of a chart band (nan when none is known)."""
    values = [h for row in band.values() for h in row.values() if math.isfinite(h)]
    return max(values) if values else math.nan
