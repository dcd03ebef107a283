"""What a session checks after connecting and before it enables the drive: the drive's
own limits against the rig file's trips, the planned constant-velocity strokes against the
drive's acceleration limit, and the DAQ's frame rate against its stated rate. Each refusal
is a ConfigError naming the rig file's key; nothing has moved."""

from __future__ import annotations

from collections.abc import Sequence

from shockdyno.errors import ConfigError
from shockdyno.model.stroke import Stroke
from shockdyno.rig.config import RigConfig
from shockdyno.run.control_loop import ControlLoop
from shockdyno.run.refusals import check_stroke

# The DAQ's frame rate, measured before enabling, against daq.sample_rate_hz ×
# daq.time_scale: within this factor (a wrong rate scales every velocity and ramp). It is
# measured over at least RATE_MIN_WINDOW_S and passes as soon as it agrees; a host or a
# simulated rig that stalled a moment agrees a little later, a wrong rate never does.
RATE_TOLERANCE = 1.25
RATE_MIN_WINDOW_S = 0.2
RATE_MAX_WINDOW_S = 2.0
RATE_MIN_FRAMES = 20
# The drive's own limits, read back where its register map has them: (register, the
# rig file's key, the monitor's trip attribute).
DRIVE_LIMITS = (
    ("travel_limit", "travel_m", "travel_trip_m"),
    ("velocity_limit", "velocity_m_s", "velocity_trip_m_s"),
    ("force_limit", "force_n", "force_trip_n"),
)


def check_drive_limits(rig: RigConfig, loop: ControlLoop) -> str:
    """The rig file's trips (limits with their margin) within the drive's own limits,
    where its register map has them: a drive that stops first ends a test with a fault
    instead of the session's controlled stop, and a limit the drive cannot reach is a
    rig file that describes another machine. The limits read, for the connect event."""
    names = [reg for reg, _, _ in DRIVE_LIMITS if reg in rig.registers]
    if not names:
        return ""
    got = loop.act().read(names)
    for reg, key, trip_attr in DRIVE_LIMITS:
        if reg not in got:
            continue
        trip = float(getattr(loop.stream.monitor, trip_attr))
        if not got[reg] > 0 or trip > got[reg] * (1 + 1e-6):
            raise ConfigError(
                f"{rig.source} limits.{key}: the session trips at {trip:g} (with "
                f"limits.trip_margin), beyond the drive's own {reg} of {got[reg]:g}; "
                "lower the limit (refused before enabling)"
            )
    return "; the drive's own " + ", ".join(f"{reg} {got[reg]:g}" for reg in names)


def check_strokes(rig: RigConfig, loop: ControlLoop, strokes: Sequence[Stroke]) -> float | None:
    """The drive's acceleration_limit read (where its map has it) and every planned
    constant-velocity stroke checked against it and the rig file. The limit read."""
    accel: float | None = None
    if "acceleration_limit" in rig.registers:
        accel = float(loop.act().read(["acceleration_limit"])["acceleration_limit"])
    for stroke in strokes:
        check_stroke(rig, stroke, accel)
    return accel


def check_daq_rate(rig: RigConfig, loop: ControlLoop) -> str:
    """The frames per host second against daq.sample_rate_hz × daq.time_scale, before
    the drive is enabled: a DAQ at 1 kHz described as 50 Hz reads velocities 20x low,
    and every limit and ramp timed on its clock is wrong. The rate measured, in words.

    Measured over consecutive windows of RATE_MIN_WINDOW_S (and RATE_MIN_FRAMES); the
    first window that agrees passes. A stream that stalled a moment and catches up (a
    busy host, a simulated rig starting) agrees in a later window; a wrong rate in
    none, and after RATE_MAX_WINDOW_S it is refused. A simulated rig at another speed
    than real time (time_scale != 1) may fall behind for good (a slow plant), so only
    a faster DAQ than stated is refused for it."""
    cfg = rig.daq
    expected = cfg.frames_per_host_s
    loop.catch_up(check=False)
    start = loop.clock()
    seq0, wall0 = loop.stream.seq, start
    seen: list[float] = []
    while seq0 is not None:
        loop.catch_up(check=False)
        now = loop.clock()
        frames = (loop.stream.seq or seq0) - seq0
        last = now - start >= RATE_MAX_WINDOW_S
        if (now - wall0 >= RATE_MIN_WINDOW_S and frames >= RATE_MIN_FRAMES) or last:
            measured = frames / max(now - wall0, 1e-9)
            seen.append(measured)
            slow = measured * RATE_TOLERANCE < expected and cfg.time_scale == 1.0
            if not slow and measured <= expected * RATE_TOLERANCE:
                return f"{measured:.0f} frames/s"
            if last:
                break
            seq0, wall0 = loop.stream.seq, now
    got = f"{min(seen):.0f}-{max(seen):.0f}" if seen else "no"
    raise ConfigError(
        f"DAQ {cfg.url} delivers {got} frames/s, the rig file says {expected:g} "
        f"({rig.source} daq.sample_rate_hz {cfg.sample_rate_hz:g}"
        f"{cfg.time_scale_note}): a wrong "
        "rate scales every velocity and time; refused before enabling"
    )
