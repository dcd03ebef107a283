"""What a session refuses before anything moves: a sine or a hold the rig file's limits
do not allow, or arguments that are not numbers. Each is one ConfigError line naming the
limit and the rig file's key."""

from __future__ import annotations

import math

import numpy as np

from shockdyno.errors import ConfigError
from shockdyno.model.stroke import MIN_CONSTANT_SHARE, Stroke
from shockdyno.rig.config import RigConfig

MIN_FREQUENCY_HZ = 1 / 600  # one cycle in 10 min: slower is a typo, and a test without end
# The smallest amplitude a sine may have, in LVDT counts: the rig's amplitude check
# (verify.amplitude_tolerance, 5 %) must see a few counts, and below this the ram's
# motion is the sensor's noise (a 1 nm sine ran and was only then called degraded).
MIN_AMPLITUDE_COUNTS = 100


def check_sine(
    rig: RigConfig,
    a: float,
    f: float,
    warmup: int,
    measured: int,
    peak_velocity_m_s: float | None = None,
) -> None:
    """Refuse a sine the rig must not run (ConfigError), before anything moves.
    `peak_velocity_m_s`: another periodic waveform's (a constant-velocity stroke's v);
    None: the sine's 2πfA."""
    lim = rig.limits
    if not (isinstance(a, int | float) and math.isfinite(a) and a > 0):
        raise ConfigError(f"amplitude must be > 0 m, got {a!r}")
    if not (isinstance(f, int | float) and math.isfinite(f) and f > 0):
        raise ConfigError(f"frequency must be > 0 Hz, got {f!r}")
    if f < MIN_FREQUENCY_HZ:
        raise ConfigError(
            f"frequency {f:g} Hz is a cycle of {1 / f / 60:.3g} min; the slowest a sweep runs "
            "is one cycle in 10 min; refused before moving"
        )
    smallest = MIN_AMPLITUDE_COUNTS * rig.daq.calibration.position_m_per_count
    if a < smallest:
        raise ConfigError(
            f"amplitude {a * 1e3:g} mm is below {smallest * 1e3:g} mm, "
            f"{MIN_AMPLITUDE_COUNTS} counts of the LVDT ({rig.source} "
            "daq.calibration.position_m_per_count): a motion it cannot measure; refused "
            "before moving"
        )
    for name, n, lo in (("warmup_cycles", warmup, 0), ("measured_cycles", measured, 1)):
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < lo:
            raise ConfigError(f"{name} must be a whole number >= {lo}, got {n!r}")
    if a > lim.travel_m:
        raise ConfigError(
            f"amplitude {a * 1e3:g} mm exceeds the rig's travel of ±{lim.travel_m * 1e3:g} mm "
            f"({rig.source} limits.travel_m); refused before moving"
        )
    v = 2 * math.pi * f * a if peak_velocity_m_s is None else peak_velocity_m_s
    if v > lim.velocity_m_s:
        what = "2πfA = " if peak_velocity_m_s is None else ""
        raise ConfigError(
            f"peak velocity {what}{v:.3g} m/s exceeds the limit of {lim.velocity_m_s:g} m/s "
            f"({rig.source} limits.velocity_m_s); refused before moving"
        )
    if f > rig.daq.sample_rate_hz / 20:
        raise ConfigError(f"frequency {f:g} Hz leaves fewer than 20 DAQ samples per cycle; refused")


def check_stroke(rig: RigConfig, stroke: Stroke, drive_accel_m_s2: float | None) -> None:
    """Refuse a constant-velocity stroke (model/stroke.py) the rig cannot run (ConfigError),
    before anything moves: a drive without the waveform registers, a reversal beyond the
    acceleration the drive can do (`drive_accel_m_s2`: its acceleration_limit register,
    read before enabling), a triangle whose reversal, made at that acceleration, would
    carry the ram beyond the travel, or a trapezoid mostly reversal. The speed, amplitude
    and frequency are check_sine's, with v as the peak velocity."""
    regs = rig.registers
    need = ["waveform", "acceleration_limit"]
    if stroke.waveform == "trapezoid":
        need.append("waveform_acceleration")
    missing = [n for n in need if n not in regs]
    if missing:
        raise ConfigError(
            f"{stroke.waveform} strokes need the drive's {', '.join(missing)} register"
            f"{'s' if len(missing) > 1 else ''} ({rig.source} [actuator.registers]; "
            "docs/rig.md): this drive runs sines only"
        )
    a, v = stroke.amplitude_m, stroke.velocity_m_s
    if not (math.isfinite(v) and v > 0):
        raise ConfigError(f"constant velocity must be > 0 m/s, got {v!r}")
    if drive_accel_m_s2 is None or not drive_accel_m_s2 > 0:
        raise ConfigError(
            f"the drive's acceleration_limit reads {drive_accel_m_s2!r}: a reversal cannot "
            "be checked against it; refused before moving"
        )
    if stroke.accel_m_s2 is not None:
        acc = stroke.accel_m_s2
        if not (math.isfinite(acc) and 0 < acc <= drive_accel_m_s2):
            raise ConfigError(
                f"reversal acceleration {acc:g} m/s² exceeds the drive's acceleration_limit "
                f"of {drive_accel_m_s2:g} m/s² (or is not > 0); refused before moving"
            )
        if stroke.constant_share < MIN_CONSTANT_SHARE:
            raise ConfigError(
                f"{v * 1e3:g} mm/s with reversals at {acc:g} m/s² reverses over "
                f"{stroke.rounding_m * 1e3:.3g} mm at each end of a ±{a * 1e3:g} mm stroke: "
                f"under {MIN_CONSTANT_SHARE:.0%} of it at constant velocity; use a larger "
                "amplitude or acceleration"
            )
    else:
        # A triangle's reversal is a velocity step: the ram, at v, needs v²/(2a) beyond
        # the amplitude to stop even at the drive's best.
        over = v**2 / (2 * drive_accel_m_s2)
        if a + over > rig.limits.travel_m:
            raise ConfigError(
                f"a triangle at {v * 1e3:g} mm/s reverses {over * 1e3:.3g} mm beyond its "
                f"{a * 1e3:g} mm amplitude at the drive's {drive_accel_m_s2:g} m/s², past "
                f"the rig's travel of ±{rig.limits.travel_m * 1e3:g} mm ({rig.source} "
                "limits.travel_m); refused before moving"
            )


def check_hold(
    rig: RigConfig, offset_m: float, velocity_m_s: float | None, dwell_s: float
) -> float:
    """Refuse a hold the rig must not make; the move's velocity (None: the rig's
    ramp.move_velocity_m_s)."""
    lim = rig.limits
    if velocity_m_s is None:
        velocity_m_s = rig.ramp.move_velocity_m_s
    for name, value in (("offset", offset_m), ("velocity", velocity_m_s), ("dwell", dwell_s)):
        if not (isinstance(value, int | float) and math.isfinite(value)):
            raise ConfigError(f"hold: {name} must be a finite number, got {value!r}")
    if abs(offset_m) > lim.travel_m:
        raise ConfigError(
            f"hold at {offset_m * 1e3:+g} mm exceeds the rig's travel of "
            f"±{lim.travel_m * 1e3:g} mm ({rig.source} limits.travel_m)"
        )
    if not 0 < velocity_m_s <= min(lim.velocity_m_s, rig.ramp.move_velocity_m_s):
        raise ConfigError(
            f"hold: move velocity must be > 0 and at most the rig's move velocity "
            f"{rig.ramp.move_velocity_m_s:g} m/s, got {velocity_m_s:g}"
        )
    if dwell_s <= 0:
        raise ConfigError(f"hold: dwell must be > 0 s, got {dwell_s:g}")
    return float(velocity_m_s)


def check_band(rig: RigConfig, band_c: tuple[float, float]) -> None:
    """Refuse a temperature band the damper can never be in (ConfigError): not numbers,
    LOW above HIGH, beyond the rig's temperature limit or the thermometer's range. A sweep
    would wait for it with the drive off until its timeout (30 min)."""
    lo, hi = band_c
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise ConfigError(f"--temp-band-c must be LOW,HIGH in °C with LOW <= HIGH, got {lo},{hi}")
    limit = rig.limits.temperature_c
    if lo >= limit:
        raise ConfigError(
            f"--temp-band-c {lo:g},{hi:g}: the damper would trip the rig's temperature limit "
            f"of {limit:g} °C ({rig.source} limits.temperature_c) before it got there"
        )
    t_lo, t_hi = rig.daq.temperature_range_c
    if hi < t_lo or lo > t_hi:
        raise ConfigError(
            f"--temp-band-c {lo:g},{hi:g}: outside what the thermometer reads "
            f"({t_lo:g} to {t_hi:g} °C, {rig.source} daq.temperature_range_c)"
        )
