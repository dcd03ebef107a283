"""The sweep plan: which click settings and frequencies, in which order, and what is left."""

from __future__ import annotations

import math
from dataclasses import dataclass

from shockdyno.errors import ConfigError
from shockdyno.model.stroke import CONSTANT_VELOCITY, WAVEFORMS, Stroke

DEFAULT_FREQUENCIES_HZ = (0.5, 1.0, 1.5)  # paper, Table 3
DEFAULT_AMPLITUDE_M = 0.030  # paper, Table 3 (the text's "0.03 mm" is a slip: see reference)


def parse_velocities_mm_s(text: str) -> list[float]:
    """'25,50,100,200,300' (mm/s) -> peak velocities in m/s, sorted, without duplicates."""
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ConfigError(f"bad velocities {text!r}: use e.g. 25,50,100,200,300 (mm/s)") from None
    if not values or any(not math.isfinite(v) or v <= 0 for v in values):
        raise ConfigError(f"velocities must be > 0 mm/s, got {text!r}")
    return sorted({v / 1e3 for v in values})


# The fastest target is planned this much faster: a sine touches its peak velocity at one
# instant only, and the servo's tracking leaves the measured peak a little short of the
# command (3 of 8 tests planned at exactly 300 mm/s peaked below it), so that velocity would
# be extrapolated. Every slower target is passed twice a cycle by the faster tests.
TOP_VELOCITY_MARGIN = 0.10


def frequencies_for_velocities(
    velocities_m_s: list[float], amplitude_m: float, max_velocity_m_s: float = math.inf
) -> list[float]:
    """The sine frequency that reaches each peak velocity at this amplitude: v = 2πfA.

    The fastest is planned TOP_VELOCITY_MARGIN faster, capped at `max_velocity_m_s` (the
    rig's limit), so that the click chart measures it rather than extrapolating it.
    Rounded to 5 significant digits (a peak velocity off by at most 0.005 %), so that
    frequencies read back from a recording and file names stay short.
    """
    if not (math.isfinite(amplitude_m) and amplitude_m > 0):
        raise ConfigError(f"amplitude must be > 0, got {amplitude_m * 1e3:g} mm")
    planned = list(velocities_m_s)
    if planned:
        top = max(planned)
        planned[planned.index(top)] = max(
            top, min(top * (1 + TOP_VELOCITY_MARGIN), max_velocity_m_s)
        )
    return [float(f"{v / (2 * math.pi * amplitude_m):.5g}") for v in planned]


# A trapezoid's reversal, unless --reversal-accel-m-s2 says otherwise, spends this share of
# the amplitude at each end of the stroke: a = v² / (2 · share · A), 90 % of the stroke at
# constant velocity at every speed.
DEFAULT_ROUNDING_SHARE = 0.1


def constant_velocity_strokes(
    waveform: str, velocities_m_s: list[float], amplitude_m: float, accel_m_s2: float | None
) -> list[Stroke]:
    """One stroke per velocity; a trapezoid's acceleration as given, else each speed's
    (DEFAULT_ROUNDING_SHARE)."""
    if waveform not in CONSTANT_VELOCITY:
        raise ConfigError(f"waveform {waveform!r} is not one of {', '.join(CONSTANT_VELOCITY)}")
    if not (math.isfinite(amplitude_m) and amplitude_m > 0):
        raise ConfigError(f"amplitude must be > 0, got {amplitude_m * 1e3:g} mm")
    out = []
    for v in velocities_m_s:
        a = None
        if waveform == "trapezoid":
            a = (
                accel_m_s2
                if accel_m_s2 is not None
                else v**2 / (2 * DEFAULT_ROUNDING_SHARE * amplitude_m)
            )
            a = float(f"{a:.4g}")
        out.append(Stroke(waveform, amplitude_m, v, a))
    return out


def stroke_frequency_hz(stroke: Stroke) -> float:
    """The drive's frequency for a stroke, rounded as a sine's is (5 significant digits)."""
    return float(f"{stroke.frequency_hz:.5g}")


@dataclass(frozen=True)
class SweepPoint:
    clicks: int
    gas_clicks: int
    frequency_hz: float

    @property
    def key(self) -> tuple[int, int, float]:
        return (self.clicks, self.gas_clicks, self.frequency_hz)


@dataclass(frozen=True)
class SweepPlan:
    clicks: tuple[int, ...]
    frequencies_hz: tuple[float, ...] = DEFAULT_FREQUENCIES_HZ
    amplitude_m: float = DEFAULT_AMPLITUDE_M
    gas_clicks: int = 0
    warmup_cycles: int = 2
    measured_cycles: int = 5
    temperature_band_c: tuple[float, float] | None = None
    gas_pressure_pa: float | None = None  # the charge as set on the damper, absolute
    measure_gas: bool = True  # the static gas force at each click change (run/gas_measure.py)
    # Constant-velocity tests (model/stroke.py): one stroke per frequency, in order (the
    # frequencies are theirs: stroke_frequency_hz). Empty: sines.
    strokes: tuple[Stroke, ...] = ()

    def __post_init__(self) -> None:
        if not (math.isfinite(self.amplitude_m) and self.amplitude_m > 0):
            raise ConfigError(f"amplitude must be > 0, got {self.amplitude_m * 1e3:g} mm")
        if self.warmup_cycles < 0 or self.measured_cycles < 1:
            raise ConfigError("need warm-up cycles >= 0 and measured cycles >= 1")
        if self.temperature_band_c and self.temperature_band_c[0] >= self.temperature_band_c[1]:
            raise ConfigError("temperature band must be LOW,HIGH with LOW < HIGH")
        if self.strokes:
            if [stroke_frequency_hz(s) for s in self.strokes] != list(self.frequencies_hz):
                raise ConfigError("a constant-velocity plan's frequencies are its strokes'")
            if len({s.waveform for s in self.strokes}) != 1 or any(
                s.amplitude_m != self.amplitude_m for s in self.strokes
            ):
                raise ConfigError("a plan's strokes share one waveform and the amplitude")
        gas = self.gas_pressure_pa
        if gas is not None and not (math.isfinite(gas) and 1e5 <= gas <= 1e7):
            raise ConfigError(f"gas pressure must be 1-100 bar absolute, got {gas / 1e5:g} bar")

    @property
    def waveform(self) -> str:
        return self.strokes[0].waveform if self.strokes else WAVEFORMS[0]

    def stroke(self, frequency_hz: float) -> Stroke | None:
        """The constant-velocity stroke planned at this frequency (None: a sine)."""
        for s in self.strokes:
            if stroke_frequency_hz(s) == frequency_hz:
                return s
        return None

    def points(self) -> list[SweepPoint]:
        """Clicks outer, frequency inner: the adjuster moves as rarely as possible."""
        return [SweepPoint(c, self.gas_clicks, f) for c in self.clicks for f in self.frequencies_hz]

    def remaining(self, done: set[tuple[int, int, float]]) -> list[SweepPoint]:
        return [p for p in self.points() if p.key not in done]
