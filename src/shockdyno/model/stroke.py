"""Constant-velocity strokes: the geometry of a triangle and of a rounded triangle.

A constant-velocity test drives the rod at one speed v over most of each stroke, so the
damper's force at that speed is read directly (the standard for peak-velocity charts at
low speed, where a sine passes each speed only for an instant).

- ``triangle``: constant velocity between reversals, each reversal a velocity step
  (the servo loop rounds it);
- ``trapezoid``: the same with each reversal bounded by an acceleration a (velocity
  trapezoidal in time): over ``v²/(2a)`` at each end of the stroke the ram decelerates
  and comes back, and the constant-velocity part is ``|x| <= A - v²/(2a)``.

A period is ``4A/v`` (triangle) or ``4A/v + 2v/a`` (trapezoid). The profile starts at
the centre moving in compression (phase 0, like the sine), so a whole number of cycles
ends at the centre. Units SI; the shape is of unit amplitude and has period 1 in phase.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

WAVEFORMS = ("sine", "triangle", "trapezoid")
CONSTANT_VELOCITY = ("triangle", "trapezoid")
# The least share of a trapezoid's stroke at constant velocity (1 - v²/(2aA)): below it
# the "constant-velocity" test is mostly reversal.
MIN_CONSTANT_SHARE = 0.5


@dataclass(frozen=True)
class Stroke:
    """One constant-velocity test's motion: amplitude A, speed v, reversal acceleration a
    (trapezoid only; None for a triangle)."""

    waveform: str
    amplitude_m: float
    velocity_m_s: float
    accel_m_s2: float | None = None

    @property
    def rounding_m(self) -> float:
        """The travel at each end of the stroke spent reversing: v²/(2a) (0: triangle)."""
        if self.accel_m_s2 is None:
            return 0.0
        return self.velocity_m_s**2 / (2 * self.accel_m_s2)

    @property
    def constant_share(self) -> float:
        """The share of the stroke (of 2A) travelled at constant velocity."""
        return 1.0 - self.rounding_m / self.amplitude_m

    @property
    def period_s(self) -> float:
        """One cycle (s): 4A/v, plus 2v/a where the reversals take acceleration a (a trapezoid)."""
        extra = 0.0 if self.accel_m_s2 is None else 2 * self.velocity_m_s / self.accel_m_s2
        return 4 * self.amplitude_m / self.velocity_m_s + extra

    @property
    def frequency_hz(self) -> float:
        """Cycles per second (Hz), 1 / period."""
        return 1.0 / self.period_s

    def shape(self, phase: FloatArray) -> FloatArray:
        """x / A at each phase (cycles)."""
        return unit_shape(phase, quarter_constant(self.frequency_hz, self.amplitude_m,
                                                  self.accel_m_s2))  # fmt: skip


def quarter_constant(frequency_hz: float, amplitude_m: float, accel_m_s2: float | None) -> float:
    """The share of a quarter period at constant velocity, for a drive told amplitude,
    frequency and reversal acceleration (None: a triangle, 1). NaN when no trapezoid of
    that acceleration makes that amplitude at that frequency (the reversals alone take
    longer than the period)."""
    if accel_m_s2 is None:
        return 1.0
    period = 1.0 / frequency_hz
    # 2v²/a - T v + 4A = 0, the smaller root (the larger has no constant part).
    disc = period**2 - 32 * amplitude_m / accel_m_s2
    if not (accel_m_s2 > 0 and disc >= 0):
        return math.nan
    v = (period - math.sqrt(disc)) * accel_m_s2 / 4
    return (amplitude_m / v - v / (2 * accel_m_s2)) / (period / 4)


def unit_shape(phase: FloatArray, constant: float) -> FloatArray:
    """The unit-amplitude profile at `phase` (cycles) whose quarters spend `constant` of
    their time at constant velocity and the rest at constant deceleration into the
    reversal (1: a triangle)."""
    p = np.mod(np.asarray(phase, np.float64), 1.0)
    half = np.mod(p, 0.5)
    sign = np.where(p < 0.5, 1.0, -1.0)
    q = np.minimum(half, 0.5 - half)  # 0 .. 1/4, symmetric about the reversal
    quarter = 0.25
    qc = constant * quarter
    slope = 2.0 / (quarter + qc)
    past = np.maximum(q - qc, 0.0)
    tail = quarter - qc
    bend = 0.0 if tail <= 0 else 1.0 / (2 * tail)
    return np.asarray(sign * slope * (q - bend * past**2), np.float64)
