"""The simulated servo drive's state machine and motion profile.

The commanded position is piecewise-analytic, so a whole batch of samples is computed
at once:

    x_cmd(t) = base(t) + A · env(t) · sin(2π f (t − t0))

`base` and `env` are piecewise-linear (knots, `np.interp`): moves in hold mode ramp the
base at the move velocity; a sine ramps its envelope in over the ramp cycles, holds,
and ramps out; a stop ramps the envelope to zero from wherever it is. Nothing steps.
Commands take effect at the time of the next sample the engine produces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

HEARTBEAT_LOST = 1
OVER_FORCE = 2
OVER_VELOCITY = 3
TRAVEL_LIMIT = 4
DRIVE_FAULT = 5
START_OFF_CENTRE = 6
START_BAD_PARAMS = 7

TARGET_TOLERANCE_M = 0.0005
START_TOLERANCE_M = 0.002


@dataclass
class Knots:
    t: list[float]
    y: list[float]

    def at(self, t: FloatArray) -> FloatArray:
        return np.asarray(np.interp(t, self.t, self.y), np.float64)

    def value(self, t: float) -> float:
        return float(np.interp(t, self.t, self.y))

    @property
    def end(self) -> float:
        return self.t[-1]

    @staticmethod
    def const(t: float, y: float) -> Knots:
        return Knots([t], [y])

    def ramp_to(self, t: float, target: float, rate: float) -> Knots:
        """From the value at t, ramp linearly to target at `rate` per second."""
        y0 = self.value(t)
        dur = abs(target - y0) / rate if rate > 0 else 0.0
        if dur <= 0:
            return Knots.const(t, target)
        return Knots([t, t + dur], [y0, target])


@dataclass
class DriveParams:
    centre_m: float
    travel_m: float
    force_capacity_n: float
    velocity_limit_m_s: float
    stop_time_s: float = 0.3
    quick_stop_time_s: float = 0.1


@dataclass
class SimDrive:
    params: DriveParams
    position_m: float  # last actual position (absolute)
    enabled: bool = False
    fault_code: int = 0
    mode: int = 0
    base: Knots = field(default_factory=lambda: Knots.const(0.0, 0.0))
    env: Knots = field(default_factory=lambda: Knots.const(0.0, 0.0))
    amplitude_m: float = 0.0
    frequency_hz: float = 1.0
    t0: float = 0.0
    sine_end: float = -1.0
    total_cycles: int = 0
    target_m: float = 0.0
    disable_at: float | None = None
    # registers the host sets
    position_command_m: float = 0.0
    move_velocity_m_s: float = 0.01
    sine_amplitude_m: float = 0.0
    sine_frequency_hz: float = 1.0
    sine_centre_m: float = 0.0
    sine_cycles: int = 0
    sine_ramp_cycles: int = 1
    heartbeat_timeout_ms: int = 500
    last_force_n: float = 0.0

    def __post_init__(self) -> None:
        self.base = Knots.const(0.0, self.position_m)
        self.target_m = self.position_m

    # -- the profile -------------------------------------------------------------------
    def command(self, t: FloatArray) -> FloatArray:
        x = self.base.at(t)
        if self.amplitude_m > 0 and t[-1] >= self.t0:
            phase = 2 * math.pi * self.frequency_hz * (t - self.t0)
            x = x + self.amplitude_m * self.env.at(t) * np.sin(phase)
        return x

    def motion(self, t: FloatArray) -> NDArray[np.bool_]:
        """The "motion active" output: true while a sine profile runs."""
        return (t >= self.t0) & (t < self.sine_end)

    def running(self, t: float) -> bool:
        return t < self.sine_end or t < self.base.end

    def cycle_count(self, t: float) -> int:
        if self.sine_end < 0:
            return 0
        # Cycles run: a stopped sine counts no further than its stop.
        ran = min(t, self.sine_end) - self.t0
        return int(min(max(ran * self.frequency_hz, 0.0), self.total_cycles) + 1e-9)

    # -- events ------------------------------------------------------------------------
    def _stop_motion(self, t: float, ramp_s: float, cycles: float = 1.0) -> None:
        # Ramping the envelope adds A·|env'| to the speed; over at least half a cycle the
        # peak speed stays within ~5 % of the sine's own (A ω √(1 + 1/π²)).
        ramp_s = max(ramp_s, cycles / self.frequency_hz)
        e = self.env.value(t)
        if t < self.sine_end and e > 0:
            self.env = Knots([t, t + ramp_s], [e, 0.0])
            self.sine_end = t + ramp_s
        self.base = Knots.const(t, self.base.value(t))
        self.target_m = self.base.value(t)

    def trip(self, code: int, t: float, *, disable: bool = False) -> None:
        if self.fault_code:
            return
        self.fault_code = code
        self._stop_motion(t, self.params.quick_stop_time_s, 0.5)
        if disable:
            self.disable_at = max(self.sine_end, t) + 0.05

    def tick(self, t: float) -> None:
        """Time-driven state changes (called at the start of every batch)."""
        if self.disable_at is not None and t >= self.disable_at:
            self.disable(t)

    def enable(self, t: float) -> None:
        if not self.enabled:
            self.enabled = True
            self.base = Knots.const(t, self.position_m)
            self.env = Knots.const(t, 0.0)
            self.target_m = self.position_m

    def disable(self, t: float) -> None:
        # A real drive locks the ram where it is: the host must stop and centre first.
        self.enabled = False
        self.disable_at = None
        self.base = Knots.const(t, self.position_m)
        self.env = Knots.const(t, 0.0)
        self.sine_end = min(self.sine_end, t)
        self.target_m = self.position_m

    def move(self, t: float, target: float, velocity: float) -> None:
        if not self.enabled or self.fault_code or t < self.sine_end:
            return
        self.target_m = target
        self.base = self.base.ramp_to(t, target, velocity)

    def start(self, t: float) -> None:
        if not self.enabled or self.fault_code or t < self.sine_end:
            return
        if self.mode != 1:
            self.move(t, self.position_command_m, self.move_velocity_m_s)
            return
        a, f, c = self.sine_amplitude_m, self.sine_frequency_hz, self.sine_centre_m
        n, r = self.sine_cycles, self.sine_ramp_cycles
        p = self.params
        if not (0 < a <= p.travel_m and 0 < f <= 100 and n >= 0 and r >= 1):
            self.fault_code = START_BAD_PARAMS
            return
        if abs(c - p.centre_m) + a > p.travel_m:
            self.fault_code = START_BAD_PARAMS
            return
        if abs(self.position_m - c) > START_TOLERANCE_M or abs(self.base.value(t) - c) > 1e-9:
            self.fault_code = START_OFF_CENTRE
            return
        self.amplitude_m, self.frequency_hz, self.t0 = a, f, t
        self.total_cycles = n + 2 * r
        self.env = Knots([t, t + r / f, t + (r + n) / f, t + (2 * r + n) / f], [0.0, 1.0, 1.0, 0.0])
        self.sine_end = t + self.total_cycles / f
        self.base = Knots.const(t, c)
        self.target_m = c

    def stop(self, t: float, quick: bool = False) -> None:
        p = self.params
        if quick:
            self._stop_motion(t, p.quick_stop_time_s, 0.5)
        else:
            self._stop_motion(t, p.stop_time_s, 1.0)

    def fault_reset(self) -> None:
        self.fault_code = 0

    def status_bits(self, t: float) -> dict[str, bool]:
        running = self.running(t)
        return {
            "ready": self.fault_code == 0,
            "enabled": self.enabled,
            "running": running,
            "target_reached": not running
            and abs(self.position_m - self.target_m) < TARGET_TOLERANCE_M,
            "fault": self.fault_code != 0,
            "warning": False,
        }
