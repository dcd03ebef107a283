"""One test's headline numbers: the report table and the live view's end-of-test line.

Both callers go through :func:`summarise`, so the line printed when a test ends and the
row in the report agree to the digit.

Definitions (all over the measured cycles, ``test.measured()``):

- peak compression / rebound force: max(F) and min(F), signed (rebound is usually < 0);
- peak compression / rebound velocity: max(v) and min(v), with v from
  :func:`shockdyno.model.kinematics.velocity` (Savitzky–Golay, 25 ms window, across
  the gaps of dropped frames);
- temperature: mean over the measured cycles (None when the test has no temperature);
- dropped frames: over the whole test, not only the measured cycles (see :func:`summarise`);
- with ``gas_force_n`` given, the peak forces are damping forces: force minus that static
  gas force (report/gas.py), and the line says ``gas_removed=231N``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.model.kinematics import velocity
from shockdyno.record.types import TestData, TestMeta
from shockdyno.report.constant_velocity import CvPoint, cv_points
from shockdyno.units import SI, Units

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class TestSummary:
    """Headline numbers of one test. Forces in N, velocities in m/s, signed.

    What the test was (its clicks, frequency, amplitude, motion, status, ...) is ``meta``,
    the test's own TestMeta; the fields here are what :func:`summarise` measured."""

    __test__ = False  # not a pytest test class, despite the name

    meta: TestMeta
    n_samples: int
    peak_compression_force_n: float
    peak_rebound_force_n: float
    peak_compression_velocity_m_s: float
    peak_rebound_velocity_m_s: float
    temperature_c: float | None
    # The largest count known (see summarise): at least meta.dropped_frames.
    dropped_frames: int | None
    # The gas force taken from the peak forces (None: raw force, whatever meta.gas_force_n).
    gas_removed_n: float | None = None
    # A constant-velocity test's (compression, rebound) points (report/constant_velocity.py);
    # None for a sine.
    cv: tuple[CvPoint, CvPoint] | None = None

    def _clicks(self) -> str:
        """'clicks=12', or every adjuster's: 'compression=12 rebound=4'."""
        m = self.meta
        if not m.adjusters:
            return f"clicks={m.clicks}"
        return " ".join(f"{n}={v}" for n, v in m.adjusters.items())

    def line(self, done: int | None = None, total: int | None = None, units: Units = SI) -> str:
        """One plain ASCII line (no control codes) for logs, pipes and CI; imperial units
        give in, lbf, in/s and F (SI keeps the line as it always read: mm, N, m/s, C)."""
        head = f"test {done}/{total}" if done is not None and total is not None else "test"
        imp = units.imperial
        m = self.meta
        if self.temperature_c is None:
            temp = "-"
        else:
            temp = f"{units.temperature(self.temperature_c):.1f}{'F' if imp else 'C'}"
        dropped = "?" if self.dropped_frames is None else str(self.dropped_frames)
        amp = f"{units.length(m.amplitude_m):.2f}in" if imp else f"{m.amplitude_m * 1e3:.1f}mm"
        f_unit, v_unit = ("lbf", "in/s") if imp else ("N", "m/s")
        v_scale, v_spec = (units.velocity_per_m_s, "+.2f") if imp else (1.0, "+.3f")
        return (
            f"{head} {self._clicks()} gas={m.gas_clicks} f={m.frequency_hz:.2f}Hz"
            f" A={amp}"
            f" Fc={_fmt(units.force(self.peak_compression_force_n), '+.0f')}{f_unit}"
            f" Fr={_fmt(units.force(self.peak_rebound_force_n), '+.0f')}{f_unit}"
            + (
                ""
                if self.gas_removed_n is None
                else f" gas_removed={units.force(self.gas_removed_n):.0f}{f_unit}"
            )
            + self._cv_text(units)
            + f" vc={_fmt(self.peak_compression_velocity_m_s * v_scale, v_spec)}{v_unit}"
            f" vr={_fmt(self.peak_rebound_velocity_m_s * v_scale, v_spec)}{v_unit}"
            f" T={temp} dropped={dropped} {m.status}"
        )

    def point(self, direction: int) -> tuple[float, float]:
        """(velocity, force) on the peak-velocity chart in a direction (0 compression, 1
        rebound): the peaks, or a constant-velocity test's mean force at its speed."""
        if self.cv is not None:
            p = self.cv[direction]
            return p.velocity_m_s, p.force_n
        if direction == 0:
            return self.peak_compression_velocity_m_s, self.peak_compression_force_n
        return self.peak_rebound_velocity_m_s, self.peak_rebound_force_n

    def _cv_text(self, units: Units) -> str:
        """A constant-velocity test's speed and mean forces: ' triangle v=100mm/s
        Fcv=+150/-1325N' (in/s and lbf in imperial); empty for a sine."""
        target = self.meta.target_velocity_m_s
        if target is None:
            return ""
        imp = units.imperial
        speed = f"{target * units.velocity_per_m_s:.2f}in/s" if imp else f"{target * 1e3:.0f}mm/s"
        forces = "-"
        if self.cv is not None:
            c, r = (units.force(p.force_n) for p in self.cv)
            forces = f"{c:+.0f}/{r:+.0f}{'lbf' if imp else 'N'}"
        return f" {self.meta.motion} v={speed} Fcv={forces}"


def _fmt(value: float, spec: str) -> str:
    return "nan" if math.isnan(value) else format(value, spec)


def dropped_from_time(t: FloatArray, sample_rate_hz: float) -> int:
    """Missing samples implied by gaps in a time base that comes from a sample counter."""
    if t.size < 2 or not sample_rate_hz > 0:
        return 0
    steps = np.rint(np.diff(np.asarray(t, dtype=float)) * sample_rate_hz)
    return int(np.sum(np.clip(steps - 1, 0, None)))


def summarise(
    test: TestData, dropped_frames: int | None = None, gas_force_n: float | None = None
) -> TestSummary:
    """Headline numbers of ``test`` (see the module docstring for the definitions).

    Dropped frames: the largest of the counts known: ``dropped_frames`` (what the live
    view counted), ``meta.dropped_frames`` (stored with the recording; an older
    recording's ``extra`` count is read into it) and the gaps in the time base (t comes
    from the DAQ's sequence
    counter, so a gap is a lost frame). Each source can miss a lost frame (gaps do not show
    frames lost after the last one received) but none invents one.
    """
    meta = test.meta
    counts = [dropped_from_time(test.t, meta.sample_rate_hz)]
    counts += [int(k) for k in (dropped_frames, meta.dropped_frames) if k is not None]
    dropped = max(counts)
    m = test.measured()
    nan = float("nan")
    f_max = f_min = v_max = v_min = nan
    if m.force.size:
        gas = 0.0 if gas_force_n is None else gas_force_n
        f_max, f_min = float(np.max(m.force)) - gas, float(np.min(m.force)) - gas
    v = velocity(m.t, m.x)
    if v.size and not np.all(np.isnan(v)):
        v_max, v_min = float(np.nanmax(v)), float(np.nanmin(v))
    temp: float | None = None
    if m.temperature is not None and np.any(np.isfinite(m.temperature)):
        temp = float(np.nanmean(m.temperature))
    return TestSummary(
        meta=meta,
        n_samples=int(m.t.size),
        peak_compression_force_n=f_max,
        peak_rebound_force_n=f_min,
        peak_compression_velocity_m_s=v_max,
        peak_rebound_velocity_m_s=v_min,
        temperature_c=temp,
        dropped_frames=dropped,
        gas_removed_n=gas_force_n,
        cv=cv_points(test, gas_force_n),
    )
