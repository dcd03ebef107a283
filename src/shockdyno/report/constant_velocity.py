"""A constant-velocity test's reading: one point per direction at its velocity.

A triangle or trapezoid test (model/stroke.py) drives the rod at one speed v over most of
each stroke. Its point in each direction is the mean force over the constant-velocity
part of the measured cycles, with its scatter:

- the constant-velocity part: samples moving in that direction within
  ``SPEED_BAND`` of v, inside ``POSITION_SHARE`` of the travel the profile spends at
  constant velocity (|x| <= A - v²/(2a): the reversals and the servo's settling after
  each are left out);
- velocity: the mean measured velocity over those samples (signed);
- force: their mean; scatter: the standard deviation of the force over them (the
  load cell's noise plus whatever the force does along the stroke at that speed: the
  gas spring's slope, hysteresis) and the spread of the per-stroke means (strokes).

The click chart reads these at the standard velocities (report/clickchart.py), and the
peak-velocity chart plots them (report/plots.py peak_curves).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from shockdyno.model.kinematics import velocity
from shockdyno.model.stroke import CONSTANT_VELOCITY, Stroke
from shockdyno.record.types import TestData

SPEED_BAND = 0.1  # a sample within 10 % of the planned speed is at constant velocity
POSITION_SHARE = 0.9  # of the constant-velocity travel, centred: the servo settles first
MIN_SAMPLES = 20


@dataclass(frozen=True)
class CvPoint:
    """One direction of a constant-velocity test: + compression, - rebound."""

    velocity_m_s: float  # mean measured, signed
    force_n: float  # mean force (the damping force when the gas force is removed)
    force_sd_n: float  # standard deviation of the force over the samples
    stroke_sd_n: float  # spread (sd) of the per-stroke means; NaN with one stroke
    samples: int
    strokes: int


def is_constant_velocity(test: TestData) -> bool:
    m = test.meta
    return m.motion in CONSTANT_VELOCITY and (m.target_velocity_m_s or 0.0) > 0


def stroke_of(test: TestData) -> Stroke:
    m = test.meta
    assert m.target_velocity_m_s is not None
    return Stroke(m.motion, m.amplitude_m, m.target_velocity_m_s, m.reversal_accel_m_s2)


def cv_points(test: TestData, gas_force_n: float | None = None) -> tuple[CvPoint, CvPoint] | None:
    """(compression, rebound) of a constant-velocity test's measured cycles, with
    `gas_force_n` taken from the force; None when it is no such test or either direction
    has fewer than MIN_SAMPLES samples at constant velocity."""
    if not is_constant_velocity(test):
        return None
    stroke = stroke_of(test)
    m = test.measured()
    if m.t.size < 3:
        return None
    v = velocity(m.t, m.x)
    force = m.force - (gas_force_n or 0.0)
    reach = POSITION_SHARE * (stroke.amplitude_m - stroke.rounding_m)
    target = stroke.velocity_m_s
    out = []
    for sign in (1.0, -1.0):
        keep = (np.abs(sign * v - target) <= SPEED_BAND * target) & (np.abs(m.x) <= reach)
        keep &= np.isfinite(force)
        n = int(np.count_nonzero(keep))
        if n < MIN_SAMPLES:
            return None
        # Strokes: runs of kept samples (a gap of more than a few samples starts another).
        idx = np.flatnonzero(keep)
        breaks = np.flatnonzero(np.diff(idx) > 5) + 1
        runs = np.split(idx, breaks)
        whole = max(r.size for r in runs)
        runs = [r for r in runs if r.size >= 0.8 * whole]  # a stroke the window cut is left out
        means = [float(np.mean(force[r])) for r in runs]
        out.append(
            CvPoint(
                velocity_m_s=float(np.mean(v[keep])),
                force_n=float(np.mean(force[keep])),
                force_sd_n=float(np.std(force[keep], ddof=1)),
                stroke_sd_n=float(np.std(means, ddof=1)) if len(means) > 1 else math.nan,
                samples=n,
                strokes=len(runs),
            )
        )
    return out[0], out[1]
