"""Did a finished test run as planned? Measured from the DAQ's own samples, not the drive.

A drive that ran another frequency, amplitude or centre than the one commanded (another
Modbus master rewrote a register, a drive ignores a setpoint) produces data labelled with
the wrong test; and a test that lost many frames has fewer samples than its label says.
Either is not "complete".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.rig.config import RigConfig, VerifyConfig
from shockdyno.rig.types import SampleBlock


@dataclass(frozen=True)
class MeasuredSine:
    frequency_hz: float
    amplitude_m: float
    centre_m: float  # relative to the stroke centre


def measure_sine(
    t: NDArray[np.float64],
    x: NDArray[np.float64],
    window: tuple[float, float],
    planned_amplitude_m: float,
    planned_frequency_hz: float,
) -> MeasuredSine | None:
    """Amplitude and centre from the extremes inside `window` (full amplitude); frequency
    from the mid-line crossings in the window widened by half a planned cycle each side
    (a crossing's time does not depend on the ramping envelope, so the ramps may lend
    theirs). None without at least two crossings to time."""
    lo_t, hi_t = window
    inside = (t >= lo_t) & (t <= hi_t)
    if np.count_nonzero(inside) < 8:
        return None
    top, bottom = float(np.max(x[inside])), float(np.min(x[inside]))
    centre = (top + bottom) / 2
    pad = 0.5 / planned_frequency_hz
    near = (t >= lo_t - pad) & (t <= hi_t + pad)
    times = _crossings(t[near], x[near] - centre, 0.2 * planned_amplitude_m)
    if times.size < 2:
        return None
    half_period = float(times[-1] - times[0]) / (times.size - 1)
    return MeasuredSine(0.5 / half_period, (top - bottom) / 2, centre)


def _crossings(t: NDArray[np.float64], y: NDArray[np.float64], band: float) -> NDArray[np.float64]:
    """Times where y crosses zero on its way from beyond -band to beyond +band or back,
    interpolated between the two samples around the last sign change (noise-proof)."""
    side = np.where(y > band, 1, np.where(y < -band, -1, 0))
    known = np.flatnonzero(side)
    if known.size < 2:
        return np.zeros(0)
    turn = np.flatnonzero(side[known][1:] != side[known][:-1])
    out = []
    for k in turn:
        a, b = int(known[k]), int(known[k + 1])
        segment = np.sign(y[a : b + 1])
        flips = np.flatnonzero(segment[1:] != segment[:-1])
        i = a + int(flips[-1])
        y0, y1 = float(y[i]), float(y[i + 1])
        frac = y0 / (y0 - y1) if y0 != y1 else 0.0
        out.append(float(t[i] + frac * (t[i + 1] - t[i])))
    return np.asarray(out)


def plan_mismatch(
    measured: MeasuredSine | None, frequency_hz: float, amplitude_m: float, tol: VerifyConfig
) -> str | None:
    """Why the measured motion is not the planned one, or None when it matches."""
    if measured is None:
        return "too few measured cycles to check the motion against the plan"
    problems = []
    if abs(measured.frequency_hz / frequency_hz - 1) > tol.frequency_tolerance:
        problems.append(f"ran at {measured.frequency_hz:.4g} Hz, planned {frequency_hz:g} Hz")
    if abs(measured.amplitude_m / amplitude_m - 1) > tol.amplitude_tolerance:
        problems.append(
            f"amplitude {measured.amplitude_m * 1e3:.4g} mm, planned {amplitude_m * 1e3:g} mm"
        )
    if abs(measured.centre_m) > tol.centre_tolerance_m:
        problems.append(f"centred {measured.centre_m * 1e3:+.3g} mm off the stroke centre")
    return "; ".join(problems) or None


def cycle_mismatch(
    t: NDArray[np.float64],
    x: NDArray[np.float64],
    window: tuple[float, float],
    amplitude_m: float,
    frequency_hz: float,
    tol: VerifyConfig,
) -> str | None:
    """The first whole cycle in `window` that did not move as planned (its half range off
    the planned amplitude, or its mid-point off the stroke centre, beyond the rig's
    tolerances), or None. The extremes over the whole window cannot see a ram that moved
    for the first cycles and sat still for the rest: each cycle must move."""
    lo_t, hi_t = window
    period = 1.0 / frequency_hz
    n = int(np.floor((hi_t - lo_t) / period + 1e-6))
    for k in range(n):
        inside = (t >= lo_t + k * period) & (t < lo_t + (k + 1) * period)
        if np.count_nonzero(inside) < 4:
            return f"cycle {k + 1} of {n} has no samples"
        top, bottom = float(np.max(x[inside])), float(np.min(x[inside]))
        half, centre = (top - bottom) / 2, (top + bottom) / 2
        if abs(half / amplitude_m - 1) > tol.amplitude_tolerance:
            return (
                f"cycle {k + 1} of {n} moved ±{half * 1e3:.3g} mm, planned "
                f"±{amplitude_m * 1e3:g} mm"
            )
        if abs(centre) > tol.centre_tolerance_m:
            return f"cycle {k + 1} of {n} centred {centre * 1e3:+.3g} mm off the stroke centre"
    return None


def frame_loss(lost: int, expected: int) -> float:
    return lost / expected if expected > 0 else (math.inf if lost else 0.0)


@dataclass(frozen=True)
class Judgement:
    status: str  # "complete" | "degraded"
    reason: str
    event: str | None  # the safety event to log ("plan_mismatch", "degraded"), if any
    stop_sweep: bool  # the drive is not doing what it is told: the sweep must stop


def judge_run(
    run: SampleBlock,
    window: tuple[float, float],
    amplitude_m: float,
    frequency_hz: float,
    rig: RigConfig,
    lost_frames: int,
) -> Judgement:
    """A finished run judged by its own samples over the measured `window` (DAQ times):
    the motion against its plan, cycle by cycle, then the frames it lost."""
    measured = measure_sine(run.t_s, run.displacement_m, window, amplitude_m, frequency_hz)
    mismatch = plan_mismatch(measured, frequency_hz, amplitude_m, rig.verify)
    if mismatch is None:
        mismatch = cycle_mismatch(
            run.t_s, run.displacement_m, window, amplitude_m, frequency_hz, rig.verify
        )
    if mismatch is not None:
        return Judgement(
            "degraded", f"test does not match its plan: {mismatch}", "plan_mismatch", True
        )
    loss = frame_loss(lost_frames, len(run) + lost_frames)
    limit = rig.daq.max_frame_loss
    if loss > limit:
        why = f"{lost_frames} frames lost ({loss:.1%} of the test; daq.max_frame_loss {limit:.1%})"
        return Judgement("degraded", why, "degraded", False)
    assert measured is not None
    return Judgement(
        "complete",
        f"{frequency_hz:g} Hz run: measured {measured.frequency_hz:.4g} Hz, "
        f"{measured.amplitude_m * 1e3:.4g} mm, centre {measured.centre_m * 1e3:+.2g} mm",
        None,
        False,
    )
