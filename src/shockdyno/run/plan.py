"""The sweep plan: which click settings and frequencies, in which order, and what is left."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from shockdyno.errors import ConfigError
from shockdyno.lists import parse_ints
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


# Every adjuster's clicks at one point of a sweep over several, by name in the spec's
# order; () for a damper with the one rod adjuster (its clicks are `clicks`).
Setting = tuple[tuple[str, int], ...]
# What identifies a test of a plan: (clicks, gas clicks, frequency, setting sorted by name).
PointKey = tuple[int, int, float, Setting]
# How a sweep over several adjusters visits their settings (docs/adjusters.md says when
# to use which): each adjuster through its list with the others at the base, or every
# combination.
DESIGNS = ("one-at-a-time", "factorial")


def parse_base(items: Sequence[str], ranges: Mapping[str, int]) -> Setting:
    """`--base NAME=N` (repeated): where a one-at-a-time sweep holds each named adjuster."""
    out: dict[str, int] = {}
    for item in items:
        name, eq, text = (s.strip() for s in item.partition("="))
        if not eq or name not in ranges:
            known = ", ".join(ranges) or "none"
            raise ConfigError(
                f"--base {item!r}: use NAME=CLICKS with an adjuster of the damper ({known})"
            )
        try:
            value = int(text)
        except ValueError:
            raise ConfigError(
                f"--base {item!r}: {text!r} is not a whole number of clicks"
            ) from None
        if not 0 <= value <= ranges[name]:
            raise ConfigError(f"--base {name}: clicks must be 0-{ranges[name]}, got {value}")
        out[name] = value
    return tuple(out.items())


def point_key(clicks: int, gas_clicks: int, frequency_hz: float, setting: Setting) -> PointKey:
    """A test's identity in a sweep (clicks, gas clicks, frequency, adjuster setting), as a
    resumed sweep matches what is done."""
    return (clicks, gas_clicks, frequency_hz, tuple(sorted(setting)))


@dataclass(frozen=True)
class SweepPoint:
    """One planned test: rod clicks, gas-bottle clicks, frequency (Hz), and each named adjuster's
    clicks where the damper has several."""

    clicks: int
    gas_clicks: int
    frequency_hz: float
    adjusters: Setting = ()

    @property
    def key(self) -> PointKey:
        """The point's identity (`point_key`)."""
        return point_key(self.clicks, self.gas_clicks, self.frequency_hz, self.adjusters)


def parse_adjust(
    items: Sequence[str], ranges: Mapping[str, int]
) -> tuple[tuple[str, tuple[int, ...]], ...]:
    """`--adjust NAME=LIST` (repeated) against the spec's adjusters {name: max clicks}:
    every adjuster once, in the spec's order, each list within its range."""
    given: dict[str, tuple[int, ...]] = {}
    names = ", ".join(ranges) or "none"
    for item in items:
        name, eq, text = item.partition("=")
        name = name.strip()
        if not eq or not text.strip():
            raise ConfigError(f"--adjust {item!r}: use NAME=CLICKS, e.g. compression=0-20:5")
        if name not in ranges:
            raise ConfigError(f"--adjust {item!r}: the damper has no adjuster {name!r} ({names})")
        if name in given:
            raise ConfigError(f"--adjust {name} is given twice")
        values = parse_ints(text, f"--adjust {name}")
        top = ranges[name]
        bad = [v for v in values if not 0 <= v <= top]
        if bad:
            raise ConfigError(f"--adjust {name}: clicks must be 0-{top}, got {bad[0]}")
        given[name] = tuple(values)
    missing = [n for n in ranges if n not in given]
    if missing:
        raise ConfigError(
            f"--adjust: the damper's adjusters are {names}; give each (a single value holds "
            f"one, e.g. --adjust {missing[0]}=10)"
        )
    return tuple((n, given[n]) for n in ranges)


@dataclass(frozen=True)
class SweepPlan:
    """A sweep: which clicks (or adjuster settings, one at a time or factorial) at which
    frequencies (Hz), the amplitude (m), warm-up and measured cycles, a temperature band (°C) to
    wait for, the gas charge (Pa, absolute), whether to measure the gas force at each click
    change, and constant-velocity strokes instead of sines."""

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
    # A sweep over several adjusters (`--adjust`): each one's clicks, in the spec's order;
    # `clicks` is then unused. Empty: the one rod adjuster at `clicks`.
    adjust: tuple[tuple[str, tuple[int, ...]], ...] = ()
    design: str = "one-at-a-time"
    held: Setting = ()  # `--base`: where one-at-a-time holds these adjusters (else the middle)

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

        if self.design not in DESIGNS:
            raise ConfigError(f"--design must be {' or '.join(DESIGNS)}, got {self.design!r}")
        if self.held and self.design != "one-at-a-time":
            raise ConfigError("--base goes with --design one-at-a-time (factorial holds none)")
        unknown = [n for n, _ in self.held if n not in dict(self.adjust)]
        if unknown:
            raise ConfigError(f"--base {unknown[0]}: not an adjuster of --adjust")

    @property
    def waveform(self) -> str:
        """The tests' waveform: `sine`, or the strokes' (`triangle`, `trapezoid`)."""
        return self.strokes[0].waveform if self.strokes else WAVEFORMS[0]

    def stroke(self, frequency_hz: float) -> Stroke | None:
        """The constant-velocity stroke planned at this frequency (None: a sine)."""
        for s in self.strokes:
            if stroke_frequency_hz(s) == frequency_hz:
                return s
        return None

    def base(self) -> Setting:
        """The setting a one-at-a-time sweep holds the other adjusters at: `--base` where
        given, else the middle of each one's list (the lower middle of an even count)."""
        given = dict(self.held)
        return tuple((n, given.get(n, sorted(v)[(len(v) - 1) // 2])) for n, v in self.adjust)

    def settings(self) -> list[Setting]:
        """Every adjuster setting the plan visits, in order (the base first)."""
        if self.design == "factorial":
            names = [n for n, _ in self.adjust]
            combos = itertools.product(*(v for _, v in self.adjust))
            return [tuple(zip(names, c, strict=True)) for c in combos]
        base = self.base()
        out = [base]
        for name, values in self.adjust:
            for v in values:
                s = tuple((n, v if n == name else b) for n, b in base)
                if s not in out:
                    out.append(s)
        return out

    def points(self) -> list[SweepPoint]:
        """Clicks outer, frequency inner: the adjuster moves as rarely as possible."""
        if self.adjust:
            # `clicks` of a test over several adjusters: the first adjuster's, for a
            # reader that knows one (recordings/FORMAT.md)
            return [
                SweepPoint(s[0][1], self.gas_clicks, f, s)
                for s in self.settings()
                for f in self.frequencies_hz
            ]
        return [SweepPoint(c, self.gas_clicks, f) for c in self.clicks for f in self.frequencies_hz]

    def remaining(self, done: set[PointKey]) -> list[SweepPoint]:
        """The planned tests not in `done` (keys), in plan order: what a resumed sweep runs."""
        return [p for p in self.points() if p.key not in done]

    def motion_s(self, ramp_cycles: int, points: Sequence[SweepPoint]) -> float:
        """Seconds the drive moves for `points`: each test's ramp in and out
        (`ramp_cycles` each, the rig's sine_ramp_cycles), warm-up and measured cycles at
        its frequency. Click changes, gas measurements and temperature waits come on top."""
        cycles = 2 * ramp_cycles + self.warmup_cycles + self.measured_cycles
        return sum(cycles / p.frequency_hz for p in points)


LONG_SWEEP_S = 600.0  # a sweep planned longer than this says how long before it starts


def duration_text(seconds: float) -> str:
    """A long duration as a person says it: '12 min', '3 h 20 min', '2 d 7 h'."""
    minutes = max(1, round(seconds / 60))
    days, rest = divmod(minutes, 24 * 60)
    hours, mins = divmod(rest, 60)
    if days:
        return f"{days} d {hours} h"
    if hours:
        return f"{hours} h {mins} min"
    return f"{mins} min"
