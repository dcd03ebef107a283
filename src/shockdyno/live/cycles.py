"""A test's samples cut into cycles as they arrive, with the planned motion beside them.

The plan is the sine the session asked the drive for (run/session.py `run_sine`):

    x_plan(t) = A · env(t) · sin(2π f (t − t0))

from the stroke centre, where t0 is the first sample with the drive's "motion active"
bit (the DAQ's status, the same instant the session takes as the start), and env ramps
linearly from 0 to 1 over the rig's ramp cycles, holds for the warm-up and measured
cycles, and ramps back to 0 (the drive's register contract: `sine_ramp_cycles`). A
recording without that bit (an import) has no plan and is cut from its measured window.

No I/O: the publisher (publisher.py) feeds it and sends what it returns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.record.schemas import display_velocity
from shockdyno.record.types import TestMeta
from shockdyno.rig.frames import STATUS_MOTION
from shockdyno.samples import SampleBlock

FloatArray = NDArray[np.float64]

PARTS = ("ramp-in", "warm-up", "measured", "ramp-out")
CONTEXT = 2  # samples each side of a display velocity's central difference (schemas.py)


@dataclass(frozen=True)
class Cycle:
    """One whole cycle of a test: what an F–x and F–v loop is drawn from."""

    index: int  # cycle of the test, from 0 (the first ramp-in cycle)
    part: str  # ramp-in, warm-up, measured, ramp-out
    t_start_s: float
    t_s: FloatArray
    displacement_m: FloatArray
    velocity_m_s: FloatArray
    force_n: FloatArray
    commanded_m: FloatArray | None  # None: no plan (no motion bit)


@dataclass(frozen=True)
class Stretch:
    """A block's samples with the plan beside them (None outside a test's plan)."""

    t_s: FloatArray
    displacement_m: FloatArray
    velocity_m_s: FloatArray
    force_n: FloatArray
    commanded_m: FloatArray | None


def planned_position(
    t_s: FloatArray, t0: float, amplitude_m: float, frequency_hz: float, cycles: int, ramp: int
) -> FloatArray:
    """The planned sine at times t_s (m from the stroke centre, + compression)."""
    knots = np.array([0.0, ramp, ramp + cycles, 2 * ramp + cycles]) / frequency_hz + t0
    env = np.interp(t_s, knots, [0.0, 1.0, 1.0, 0.0], left=0.0, right=0.0)
    return amplitude_m * env * np.sin(2 * math.pi * frequency_hz * (t_s - t0))


class CycleCutter:
    """Feed it a test's blocks in order; it returns each block's stretch and every cycle
    the block completed."""

    def __init__(self) -> None:
        self.meta: TestMeta | None = None
        self.ramp_cycles = 1  # the session's `cmd_ramp_cycles`, when it says so
        self._t0: float | None = None
        self._tail: tuple[FloatArray, FloatArray] | None = None  # velocity context
        self._held: list[tuple[FloatArray, ...]] = []  # samples of the cycle in progress
        self._recent: tuple[FloatArray, FloatArray, FloatArray] | None = None  # last block's end
        self._next = 0  # the next cycle to complete

    def begin(self, meta: TestMeta) -> None:
        """Start a test: its metadata (the plan's amplitude, frequency and cycles), nothing held."""
        self.meta = meta
        self._t0 = None
        self._tail = None
        self._held = []
        self._recent = None
        self._next = 0

    def end(self) -> None:
        """End the test: a cycle left incomplete is dropped."""
        self.meta = None
        self._tail = None
        self._held = []

    def actuator(self, fields: dict[str, float | int | bool | str]) -> None:
        """Take the ramp cycles the session commanded (`cmd_ramp_cycles`) from an actuator
        record."""
        ramp = fields.get("cmd_ramp_cycles")
        if isinstance(ramp, int | float) and not isinstance(ramp, bool) and ramp >= 1:
            self.ramp_cycles = int(ramp)

    @property
    def _total(self) -> int:
        m = self.meta
        assert m is not None
        return m.warmup_cycles + m.measured_cycles + 2 * self.ramp_cycles

    def _start(self) -> float | None:
        """t0 of the cycles: the motion bit's first sample, else the measured window's
        start less the cycles before it (an imported or replayed test without the bit)."""
        m = self.meta
        if self._t0 is not None or m is None:
            return self._t0
        if m.measured_start_s is not None and m.frequency_hz > 0:
            return m.measured_start_s - (m.warmup_cycles + self.ramp_cycles) / m.frequency_hz
        return None

    def _velocity(self, t: FloatArray, x: FloatArray) -> FloatArray:
        if self._tail is not None:
            t_all = np.concatenate((self._tail[0], t))
            x_all = np.concatenate((self._tail[1], x))
        else:
            t_all, x_all = t, x
        self._tail = (t_all[-4:], x_all[-4:])
        return display_velocity(t_all, x_all)[len(t_all) - len(t) :].astype(np.float64)

    def feed(self, block: SampleBlock) -> tuple[Stretch, list[Cycle]]:
        """The block's stretch (its samples, display velocity in m/s, and the planned position
        where there is a plan) and every cycle it completed; cycles count from the motion bit's
        first sample, or from the measured window without one."""
        t, x, force = block.t_s, block.displacement_m, block.force_n
        v = self._velocity(t, x)
        m = self.meta
        if m is None:
            return Stretch(t, x, v, force, None), []
        if self._t0 is None:
            moving = np.flatnonzero((block.status & STATUS_MOTION) != 0)
            if moving.size:
                self._t0 = float(t[moving[0]])
        t0 = self._start()
        planned = None
        if self._t0 is not None:
            n = m.warmup_cycles + m.measured_cycles
            planned = planned_position(
                t, self._t0, m.amplitude_m, m.frequency_hz, n, self.ramp_cycles
            )
        stretch = Stretch(t, x, v, force, planned)
        recent, self._recent = self._recent, (t[-CONTEXT:], x[-CONTEXT:], force[-CONTEXT:])
        if t0 is None:
            return stretch, []
        if not self._held and recent is not None:  # the samples just before, as context
            self._held.append((*recent, np.full(recent[0].size, np.nan)))
        period = 1.0 / m.frequency_hz
        self._held.append((t, x, force, np.full(t.size, np.nan) if planned is None else planned))
        done: list[Cycle] = []
        # A cycle is cut once CONTEXT samples past its end are in, so its velocity is a
        # central difference to its last sample whatever the blocks' sizes.
        after = CONTEXT / m.sample_rate_hz if m.sample_rate_hz > 0 else 0.0
        while self._next < self._total and t[-1] >= t0 + (self._next + 1) * period + after:
            done.append(self._cut(t0 + self._next * period, t0 + (self._next + 1) * period))
            self._next += 1
        return stretch, done

    def _part(self, k: int) -> str:
        m, r = self.meta, self.ramp_cycles
        assert m is not None
        ends = np.cumsum([r, m.warmup_cycles, m.measured_cycles])
        return PARTS[int(np.searchsorted(ends, k, side="right"))]

    def _cut(self, lo: float, hi: float) -> Cycle:
        t, x, force, plan = (np.concatenate([h[i] for h in self._held]) for i in range(4))
        v = display_velocity(t, x, CONTEXT).astype(np.float64)
        m = self.meta
        assert m is not None
        # Half a sample early: a boundary on a sample (t0 is one) is not split by rounding.
        half = 0.5 / m.sample_rate_hz if m.sample_rate_hz > 0 else 0.0
        inside = (t >= lo - half) & (t < hi - half)
        # The next cycle keeps CONTEXT samples before its start for its own velocity.
        first = max(0, int(np.searchsorted(t, hi - half)) - CONTEXT)
        self._held = [(t[first:], x[first:], force[first:], plan[first:])]
        planned = plan[inside]
        return Cycle(
            index=self._next,
            part=self._part(self._next),
            t_start_s=lo,
            t_s=t[inside],
            displacement_m=x[inside],
            velocity_m_s=v[inside],
            force_n=force[inside],
            commanded_m=None if np.isnan(planned).all() else planned,
        )
