"""Tests as the fit uses them: measured cycles on a uniform time base, with v and a.

Imported data may be sampled unevenly, hold NaNs (a dropped frame) or repeat a time
stamp; those samples are dropped and the rest linearly resampled onto a uniform grid at
the median step, because `differentiate` needs a uniform time base. Velocity and
acceleration come from `differentiate` (Savitzky-Golay), at the full rate.

The fit's objective (eq. 8) runs on a decimated subset of samples, every k-th, with k
chosen so that about `rate_hz` samples per second remain (200 Hz by default: 400
samples per cycle at 0.5 Hz, 133 at 1.5 Hz, far more than the force's shape needs).
A common rate keeps eq. 8's weighting per unit time, like the full-rate sum.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from shockdyno.model.kinematics import differentiate
from shockdyno.record.types import TestData

FloatArray = NDArray[np.float64]

OBJECTIVE_RATE_HZ = 200.0
MIN_SAMPLES = 20
# A test moved when its half range is this many times the LVDT's noise: pure noise over
# thousands of samples spans about ±4σ, so a parked ram's ±1 µm never passes, and a
# 0.1 mm stroke on a 1 µm LVDT does.
MOTION_SNR = 20.0

# A short test still constrains the fit; only a check between cycles needs two of them.
FITTED_ANYWAY = "fitted anyway, with no second cycle to check it against"


def lvdt_noise_m(x: FloatArray) -> float:
    """The displacement channel's noise σ from its third differences (robust MAD): a
    smooth stroke contributes A ω³ dt³ to them, 2.5e-8 m for 30 mm at 1.5 Hz and 1 kHz,
    far below any LVDT's noise, while white noise gives σ √20."""
    if x.size < 8:
        return 0.0
    d3 = np.diff(x, 3)
    return float(1.4826 * np.median(np.abs(d3 - np.median(d3))) / np.sqrt(20.0))


def whole_cycles(d: TestData) -> float:
    """How many cycles of its frequency the test's measured samples span."""
    if d.t.size < 2 or not d.meta.frequency_hz > 0:
        return 0.0
    dt = float(d.t[1] - d.t[0])
    return float((d.t[-1] - d.t[0] + dt) * d.meta.frequency_hz)


# A click setting: rod clicks, gas clicks and every adjuster's clicks of a damper with
# several, sorted by name (() for the one rod adjuster). One group of bleed areas each.
ClickKey = tuple[int, int, tuple[tuple[str, int], ...]]


@dataclass(frozen=True)
class PreparedTest:
    data: TestData  # measured cycles, uniform time base
    v: FloatArray
    a: FloatArray
    obj: NDArray[np.intp]  # indices of the samples the objective uses

    @property
    def key(self) -> ClickKey:
        """The click setting: rod and gas clicks, and every adjuster's of a damper with
        several (() for the one rod adjuster)."""
        m = self.data.meta
        return (m.clicks, m.gas_clicks, m.setting)


def _uniform(test: TestData) -> TestData | None:
    d = test.measured()
    t = np.asarray(d.t, dtype=float)
    x = np.asarray(d.x, dtype=float)
    f = np.asarray(d.force, dtype=float)
    temp = None if d.temperature is None else np.asarray(d.temperature, dtype=float)
    ok = np.isfinite(t) & np.isfinite(x) & np.isfinite(f)
    if np.count_nonzero(ok) < MIN_SAMPLES:
        return None
    t, x, f = t[ok], x[ok], f[ok]
    if temp is not None:
        temp = temp[ok]
    order = np.argsort(t, kind="stable")
    t, x, f = t[order], x[order], f[order]
    temp = None if temp is None else temp[order]
    keep = np.concatenate([[True], np.diff(t) > 0])
    t, x, f = t[keep], x[keep], f[keep]
    temp = None if temp is None else temp[keep]
    if t.size < MIN_SAMPLES:
        return None
    steps = np.diff(t)
    dt = float(np.median(steps))
    if np.max(np.abs(steps - dt)) > 0.005 * dt:
        grid = t[0] + dt * np.arange(int(np.floor((t[-1] - t[0]) / dt + 1e-6)) + 1)
        x, f = np.interp(grid, t, x), np.interp(grid, t, f)
        if temp is not None:
            good = np.isfinite(temp)
            temp = np.interp(grid, t[good], temp[good]) if np.any(good) else None
        t = grid
    return replace(d, t=t, x=x, force=f, temperature=temp)


def locked_step(period_samples: float, nominal: int) -> int:
    """The objective step near `nominal` (0.7-1.4 times it) whose grid drifts least
    against the cycle: a 1.5 Hz cycle at 1 kHz is 666.7 samples, which every 10th sample
    meets 3.3 ms later each cycle (every 9th, 0.67 ms). A drifting grid samples a force
    that turns within a few ms of a reversal at a different point each cycle, and the
    diagnosis then reads that shape as cycle-to-cycle noise."""
    if not period_samples > 0 or nominal <= 1:
        return max(nominal, 1)
    lo, hi = max(1, round(0.7 * nominal)), max(1, round(1.4 * nominal))

    def drift(k: int) -> float:
        r = period_samples % k
        return min(r, k - r)

    return min(range(lo, hi + 1), key=lambda k: (round(drift(k), 6), abs(k - nominal)))


def prepare_tests(
    tests: Sequence[TestData], rate_hz: float = OBJECTIVE_RATE_HZ, phase_locked: bool = False
) -> tuple[list[PreparedTest], list[str]]:
    """The usable tests, and a note for each test left out.

    `phase_locked` (the diagnosis): each test's objective step is the one near the rate
    whose samples fall at the same phase in every cycle (`locked_step`). At 1.5 Hz that
    cuts the drift fivefold but not the scatter it causes: a 16.7 ms phase bin holds one
    or two samples of either grid (benchmarks/results/diagnose-notebook.md, "What set the
    noise").

    Tried and left out: starting successive tests' grids at offsets spread over the step
    (so the sweep's objective meets every millisecond after a reversal). On reference-
    plant seeds 708 and 713 it named friction beside 0.5 % air where the fixed grid did
    not (E_t 0.0092 -> 0.0052 on both), but the seal-turn calibration then took a 15-30 N
    breakaway alone (friction#1 missed on both seeds, friction#2 on 713)."""
    out: list[PreparedTest] = []
    notes: list[str] = []
    for test in tests:
        m = test.meta
        if m.status != "complete":  # stopped early: its cycles are not the ones planned
            notes.append(f"test {m.index} ({m.clicks} clicks, {m.frequency_hz:g} Hz): {m.status}")
            continue
        d = _uniform(test)
        if d is None:
            notes.append(
                f"test {m.index} ({m.clicks} clicks, {m.frequency_hz:g} Hz): too few samples"
            )
            continue
        half = 0.5 * float(np.ptp(d.x))
        noise = lvdt_noise_m(d.x)
        if half <= MOTION_SNR * noise or half <= 0 or float(np.ptp(d.force)) <= 0:
            why = (
                "no force"
                if half > MOTION_SNR * noise and half > 0
                else f"no motion: the ram moved ±{half * 1e6:.3g} µm against "
                f"{noise * 1e6:.2g} µm of LVDT noise"
            )
            notes.append(f"test {m.index} ({m.clicks} clicks, {m.frequency_hz:g} Hz): {why}")
            continue
        cycles = whole_cycles(d)
        if cycles < 2:
            notes.append(
                f"test {m.index} ({m.clicks} clicks, {m.frequency_hz:g} Hz): "
                f"only {cycles:.2g} cycles measured (fewer than two); {FITTED_ANYWAY}"
            )
        v, a = differentiate(d.t, d.x)
        dt = float(d.t[1] - d.t[0])
        step = max(1, round(1.0 / (rate_hz * dt)))
        if phase_locked and m.frequency_hz > 0:
            step = locked_step(1.0 / (m.frequency_hz * dt), step)
        obj = np.arange(0, d.t.size, step, dtype=np.intp)
        out.append(PreparedTest(data=d, v=v, a=a, obj=obj))
    return out, notes
