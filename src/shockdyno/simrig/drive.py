"""The simulated servo drive's state machine and motion profile.

The commanded position is piecewise-analytic, so a whole batch of samples is computed
at once:

    x_cmd(t) = base(t) + A · env(t) · sin(2π f (t − t0))

`base` and `env` are piecewise-linear (knots, `np.interp`): moves in hold mode ramp the
base at the move velocity; a sine ramps its envelope in over the ramp cycles, holds,
and ramps out; a stop ramps the envelope to zero from wherever it is. Nothing steps.
Commands take effect at the time of the next sample the engine produces.

A constant-velocity waveform (the `waveform` register: 1 triangle, 2 trapezoid whose
reversals take `waveform_acceleration`; model/stroke.py) runs at full amplitude and ramps
its *rate* instead: the phase's rate rises from 0 to f over the ramp cycles and falls back
at the end, so the speed never exceeds the planned v, a reversal never exceeds its
acceleration, and the travel never exceeds A (an amplitude ramp would add A·env' to the
speed: a quarter of v over one ramp cycle). A stop ramps the rate to zero where the ram
is, and holds there until it is moved.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from shockdyno.model.stroke import quarter_constant, unit_shape

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
    """A piecewise-linear function of sim time (s), held constant before the first knot and after
    the last."""

    t: list[float]
    y: list[float]

    def at(self, t: FloatArray) -> FloatArray:
        """The function's values at the times `t` (s)."""
        return np.asarray(np.interp(t, self.t, self.y), np.float64)

    def value(self, t: float) -> float:
        """The function's value at one time `t` (s)."""
        return float(np.interp(t, self.t, self.y))

    @property
    def end(self) -> float:
        """The last knot's time (s)."""
        return self.t[-1]

    def integral(self, t: FloatArray) -> FloatArray:
        """The integral from the first knot (the value held beyond the last)."""
        kt, ky = np.asarray(self.t), np.asarray(self.y)
        t = np.maximum(np.asarray(t, np.float64), kt[0])
        widths = np.diff(kt)
        cum = np.concatenate(([0.0], np.cumsum(widths * (ky[1:] + ky[:-1]) / 2)))
        i = np.clip(np.searchsorted(kt, t, side="right") - 1, 0, len(kt) - 1)
        dt = t - kt[i]
        slope = np.zeros_like(ky)
        slope[:-1] = np.diff(ky) / np.where(widths > 0, widths, 1.0)
        inside = i < len(kt) - 1
        return np.asarray(cum[i] + ky[i] * dt + np.where(inside, slope[i] * dt**2 / 2, 0.0))

    @staticmethod
    def const(t: float, y: float) -> Knots:
        """`y` from time `t` on (one knot)."""
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
    """The simulated drive's own properties: stroke centre (m, absolute), travel either side of
    it (m), force capacity (N), velocity limit (m/s), stop and quick-stop ramp times (s), the
    most acceleration a reversal may ask (m/s²)."""

    centre_m: float
    travel_m: float
    force_capacity_n: float
    velocity_limit_m_s: float
    stop_time_s: float = 0.3
    quick_stop_time_s: float = 0.1
    accel_limit_m_s2: float = 50.0  # the most a reversal may ask (a trapezoid's acceleration)


@dataclass
class SimDrive:
    """The simulated drive: the registers the host sets, its state (enabled, fault code, mode)
    and the commanded motion profile as knots of sim time, evaluated for a whole batch of samples
    at once."""

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
    waveform: int = 0  # 0 sine, 1 triangle, 2 trapezoid
    waveform_accel_m_s2: float = 0.0  # a trapezoid's reversal acceleration
    last_force_n: float = 0.0
    # A constant-velocity profile under way: its quarters' constant share (None: none),
    # the phase's rate (cycles/s) and the phase at the rate's first knot.
    cv_constant: float | None = None
    rate: Knots = field(default_factory=lambda: Knots.const(0.0, 0.0))
    phase0: float = 0.0

    def __post_init__(self) -> None:
        self.base = Knots.const(0.0, self.position_m)
        self.target_m = self.position_m

    # -- the profile -------------------------------------------------------------------
    def command(self, t: FloatArray) -> FloatArray:
        """The commanded ram position (m, absolute) at each sim time `t` (s): base plus the sine
        (or the constant-velocity stroke)."""
        x = self.base.at(t)
        if self.cv_constant is not None:
            phase = self.phase0 + self.rate.integral(t)
            return x + self.amplitude_m * unit_shape(phase, self.cv_constant)
        if self.amplitude_m > 0 and t[-1] >= self.t0:
            phase = 2 * math.pi * self.frequency_hz * (t - self.t0)
            x = x + self.amplitude_m * self.env.at(t) * np.sin(phase)
        return x

    def motion(self, t: FloatArray) -> NDArray[np.bool_]:
        """The "motion active" output: true while a sine profile runs."""
        return (t >= self.t0) & (t < self.sine_end)

    def running(self, t: float) -> bool:
        """Whether a profile (a sine, a stroke, a hold-mode move) is still under way at `t` (s)."""
        return t < self.sine_end or t < self.base.end

    def cycle_count(self, t: float) -> int:
        """Full cycles the sine has run by `t` (s), ramps included; a stopped sine counts no
        further than its stop."""
        if self.sine_end < 0:
            return 0
        # Cycles run: a stopped sine counts no further than its stop.
        ran = min(t, self.sine_end) - self.t0
        return int(min(max(ran * self.frequency_hz, 0.0), self.total_cycles) + 1e-9)

    # -- events ------------------------------------------------------------------------
    def _stop_motion(self, t: float, ramp_s: float, cycles: float = 1.0) -> None:
        if self.cv_constant is not None:
            self._stop_cv(t, ramp_s)
            return
        # Ramping the envelope adds A·|env'| to the speed; over at least half a cycle the
        # peak speed stays within ~5 % of the sine's own (A ω √(1 + 1/π²)).
        ramp_s = max(ramp_s, cycles / self.frequency_hz)
        e = self.env.value(t)
        if t < self.sine_end and e > 0:
            self.env = Knots([t, t + ramp_s], [e, 0.0])
            self.sine_end = t + ramp_s
        elif t < self.sine_end:
            # Stopped before its envelope rose (a stop in the start's own instant, as a
            # Ctrl-C right after it): nothing to ramp out, and the sine must not run on.
            self.env = Knots.const(t, 0.0)
            self.sine_end = t
        self.base = Knots.const(t, self.base.value(t))
        self.target_m = self.base.value(t)

    def _stop_cv(self, t: float, ramp_s: float) -> None:
        """The rate ramps to zero over `ramp_s` (no cycle minimum: nothing adds to the
        speed here); the ram then holds where the phase stopped."""
        if t < self.sine_end:
            phase = float(self.phase0 + self.rate.integral(np.array([t]))[0])
            self.rate = Knots([t, t + ramp_s], [self.rate.value(t), 0.0])
            self.phase0 = phase
            self.sine_end = t + ramp_s
        self.target_m = float(self.command(np.array([self.sine_end]))[0])

    def _settle(self, t: float) -> None:
        """A constant-velocity profile that has ended leaves the ram where it stopped: that
        becomes the base, and the profile is gone."""
        if self.cv_constant is not None and t >= self.sine_end:
            x = float(self.command(np.array([t]))[0])
            self.cv_constant = None
            self.amplitude_m = 0.0
            self.base = Knots.const(t, x)
            self.target_m = x

    def trip(self, code: int, t: float, *, disable: bool = False) -> None:
        """Set a fault code (the first one stays) and make the quick stop; with `disable`,
        disable shortly after the stop ends."""
        if self.fault_code:
            return
        self.fault_code = code
        self._stop_motion(t, self.params.quick_stop_time_s, 0.5)
        if disable:
            self.disable_at = max(self.sine_end, t) + 0.05

    def tick(self, t: float) -> None:
        """Time-driven state changes (called at the start of every batch)."""
        self._settle(t)
        if self.disable_at is not None and t >= self.disable_at:
            self.disable(t)

    def enable(self, t: float) -> None:
        """Enable where the ram stands (nothing moves)."""
        if not self.enabled:
            self.enabled = True
            self.base = Knots.const(t, self.position_m)
            self.env = Knots.const(t, 0.0)
            self.target_m = self.position_m

    def disable(self, t: float) -> None:
        """Disable and lock the ram where it is (a profile under way ends at once)."""
        # A real drive locks the ram where it is: the host must stop and centre first.
        self.enabled = False
        self.disable_at = None
        self.cv_constant = None
        self.base = Knots.const(t, self.position_m)
        self.env = Knots.const(t, 0.0)
        self.sine_end = min(self.sine_end, t)
        self.target_m = self.position_m

    def move(self, t: float, target: float, velocity: float) -> None:
        """Ramp to `target` (m, absolute) at `velocity` (m/s) in hold mode; ignored when
        disabled, faulted or a profile runs."""
        if not self.enabled or self.fault_code or t < self.sine_end:
            return
        self._settle(t)
        self.target_m = target
        self.base = self.base.ramp_to(t, target, velocity)

    def start(self, t: float) -> None:
        """The start command: in sine mode, the sine or stroke the registers describe (fault 7
        for bad parameters, fault 6 unless the ram is within 2 mm of the sine's centre); in hold
        mode, the move to `position_command`."""
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
        self._settle(t)
        if abs(self.position_m - c) > START_TOLERANCE_M or abs(self.base.value(t) - c) > 1e-9:
            self.fault_code = START_OFF_CENTRE
            return
        if self.waveform != 0:
            self._start_cv(t)
            return
        self.amplitude_m, self.frequency_hz, self.t0 = a, f, t
        self.total_cycles = n + 2 * r
        self.env = Knots([t, t + r / f, t + (r + n) / f, t + (2 * r + n) / f], [0.0, 1.0, 1.0, 0.0])
        self.sine_end = t + self.total_cycles / f
        self.base = Knots.const(t, c)
        self.target_m = c

    def _start_cv(self, t: float) -> None:
        a, f, c = self.sine_amplitude_m, self.sine_frequency_hz, self.sine_centre_m
        n, r = self.sine_cycles, self.sine_ramp_cycles
        accel = self.waveform_accel_m_s2
        if self.waveform == 1:
            constant = 1.0
        elif self.waveform == 2 and 0 < accel <= self.params.accel_limit_m_s2:
            constant = quarter_constant(f, a, accel)
        else:
            constant = math.nan
        if not math.isfinite(constant):
            self.fault_code = START_BAD_PARAMS
            return
        self.cv_constant = constant
        self.amplitude_m, self.frequency_hz, self.t0 = a, f, t
        self.total_cycles = n + 2 * r
        self.rate = Knots([t, t + r / f, t + (r + n) / f, t + (2 * r + n) / f], [0.0, f, f, 0.0])
        self.phase0 = 0.0
        self.env = Knots.const(t, 0.0)
        self.sine_end = t + self.total_cycles / f
        self.base = Knots.const(t, c)
        self.target_m = c

    def stop(self, t: float, quick: bool = False) -> None:
        """Ramp the motion out over the stop time (quick: the quick-stop time; a sine's envelope
        over at least a cycle, half a cycle when quick) and hold where it ends."""
        p = self.params
        if quick:
            self._stop_motion(t, p.quick_stop_time_s, 0.5)
        else:
            self._stop_motion(t, p.stop_time_s, 1.0)

    def fault_reset(self) -> None:
        """Clear the fault code."""
        self.fault_code = 0

    def status_bits(self, t: float) -> dict[str, bool]:
        """The status word's bits at `t` (s): ready, enabled, running, target reached (stopped
        within 0.5 mm of the target), fault, warning."""
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
