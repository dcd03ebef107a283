"""Did a finished test run as planned? Measured from the DAQ's own samples, not the drive.

A drive that ran another frequency, amplitude or centre than the one commanded (another
Modbus master rewrote a register, a drive ignores a setpoint) produces data labelled with
the wrong test; and a test that lost many frames has fewer samples than its label says.
Either is not "complete".

Memory is bounded whatever the test's length: a run is kept as per-cycle
extremes over its measured window (a few numbers a cycle) and the last `MAX_KEPT_SAMPLES`
samples (`RunKeeper`); the motion's frequency, amplitude and centre are measured on those,
every cycle's range on the extremes. A test of up to MAX_KEPT_SAMPLES is judged on every
sample, as before.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.rig.config import RigConfig, VerifyConfig
from shockdyno.samples import SampleBlock

# The most of a run kept as samples: ~42 MB, 1000 s at 1 kHz, a cycle and a half of the
# slowest sine a sweep plans (one in 10 min).
MAX_KEPT_SAMPLES = 1_000_000


@dataclass(frozen=True)
class MeasuredSine:
    """The motion a test actually made: frequency (Hz), amplitude (m) and centre (m from the
    stroke centre)."""

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
    cycles = CycleExtremes(window, frequency_hz)
    cycles.add(t, x)
    return cycles.mismatch(amplitude_m, tol)


class CycleExtremes:
    """Per whole cycle of a measured window: how many samples, the highest and the lowest,
    accumulated block by block (memory: three numbers a cycle)."""

    def __init__(self, window: tuple[float, float], frequency_hz: float) -> None:
        self.lo_t = window[0]
        self.period = 1.0 / frequency_hz
        n = max(0, int(np.floor((window[1] - window[0]) / self.period + 1e-6)))
        self.count = np.zeros(n, np.int64)
        self.top = np.full(n, -np.inf)
        self.bottom = np.full(n, np.inf)

    def add(self, t: NDArray[np.float64], x: NDArray[np.float64]) -> None:
        """Count the samples and keep the highest and lowest displacement of each whole cycle
        they fall in."""
        n = self.count.size
        if not n or not t.size:
            return
        k = np.floor((t - self.lo_t) / self.period).astype(np.int64)
        inside = (k >= 0) & (k < n)
        k, xs = k[inside], x[inside]
        np.add.at(self.count, k, 1)
        np.maximum.at(self.top, k, xs)
        np.minimum.at(self.bottom, k, xs)

    def mismatch(self, amplitude_m: float, tol: VerifyConfig) -> str | None:
        """The first cycle that did not move as planned (see `cycle_mismatch`), or None."""
        n = self.count.size
        for k in range(n):
            if self.count[k] < 4:
                return f"cycle {k + 1} of {n} has no samples"
            top, bottom = float(self.top[k]), float(self.bottom[k])
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
    """The share of `expected` frames that were `lost` (inf when none were expected but some
    lost)."""
    return lost / expected if expected > 0 else (math.inf if lost else 0.0)


@dataclass(frozen=True)
class Judgement:
    """A finished test judged by its samples: `complete` or `degraded`, why, the event to log,
    and whether the sweep must stop."""

    status: str  # "complete" | "degraded"
    reason: str
    event: str | None  # the safety event to log ("plan_mismatch", "degraded"), if any
    stop_sweep: bool  # the drive is not doing what it is told: the sweep must stop


class RunKeeper:
    """What a running sine's judgement needs of its samples, in bounded memory: the last
    `keep` samples, and once the measured window is known (`measure`), every cycle's
    extremes in it. `samples` counts all."""

    def __init__(self, keep: int | None = None) -> None:
        self.keep = MAX_KEPT_SAMPLES if keep is None else keep
        self._blocks: deque[SampleBlock] = deque()
        self._kept = 0
        self.samples = 0
        self.trimmed = False  # samples were let go: the tail is not the whole run
        self.cycles: CycleExtremes | None = None

    def add(self, block: SampleBlock) -> None:
        """Keep a block (the oldest let go beyond `keep` samples) and add it to the cycles'
        extremes."""
        if not len(block):
            return
        self.samples += len(block)
        self._blocks.append(block)
        self._kept += len(block)
        if self.cycles is not None:
            self.cycles.add(block.t_s, block.displacement_m)
        while self._kept - len(self._blocks[0]) >= self.keep:
            self._kept -= len(self._blocks.popleft())
            self.trimmed = True

    def measure(self, window: tuple[float, float], frequency_hz: float) -> None:
        """The measured window is known: from now on every cycle's extremes are kept (the
        samples read so far are all still here: the window starts a ramp cycle later)."""
        self.cycles = CycleExtremes(window, frequency_hz)
        for b in self._blocks:
            self.cycles.add(b.t_s, b.displacement_m)

    @property
    def tail(self) -> SampleBlock:
        """The samples kept (the whole run unless `trimmed`)."""
        return SampleBlock.concat(list(self._blocks)) if self._blocks else SampleBlock.empty()


def judge_run(
    run: SampleBlock | RunKeeper,
    window: tuple[float, float],
    amplitude_m: float,
    frequency_hz: float,
    rig: RigConfig,
    lost_frames: int,
) -> Judgement:
    """A finished run judged by its own samples over the measured `window` (DAQ times):
    the motion against its plan, cycle by cycle, then the frames it lost. A `RunKeeper`'s
    run is measured on its kept samples (the end of the window, when the run was longer)
    and every cycle on its extremes."""
    if isinstance(run, RunKeeper):
        tail, n_samples, cycles = run.tail, run.samples, run.cycles
    else:
        tail, n_samples, cycles = run, len(run), None
    if cycles is None:
        cycles = CycleExtremes(window, frequency_hz)
        cycles.add(tail.t_s, tail.displacement_m)
    kept = window
    if len(tail) and tail.t_s[0] > window[0]:  # the tail: its whole cycles at the end,
        period = 1.0 / frequency_hz  # with the half cycle before them measure_sine pads
        whole = np.floor((window[1] - tail.t_s[0]) / period - 0.5 - 1e-6)
        kept = (window[1] - max(whole, 1.0) * period, window[1])
    measured = measure_sine(tail.t_s, tail.displacement_m, kept, amplitude_m, frequency_hz)
    mismatch = plan_mismatch(measured, frequency_hz, amplitude_m, rig.verify)
    if mismatch is None:
        mismatch = cycles.mismatch(amplitude_m, rig.verify)
    if mismatch is not None:
        return Judgement(
            "degraded", f"test does not match its plan: {mismatch}", "plan_mismatch", True
        )
    loss = frame_loss(lost_frames, n_samples + lost_frames)
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
