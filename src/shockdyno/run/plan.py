"""The sweep plan: which click settings and frequencies, in which order, and what is left."""

from __future__ import annotations

import math
from dataclasses import dataclass

from shockdyno.errors import ConfigError

DEFAULT_FREQUENCIES_HZ = (0.5, 1.0, 1.5)  # paper, Table 3
DEFAULT_AMPLITUDE_M = 0.030  # paper, Table 3 (the text's "0.03 mm" is a slip: see reference)


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

    def __post_init__(self) -> None:
        if not (math.isfinite(self.amplitude_m) and self.amplitude_m > 0):
            raise ConfigError(f"amplitude must be > 0, got {self.amplitude_m * 1e3:g} mm")
        if self.warmup_cycles < 0 or self.measured_cycles < 1:
            raise ConfigError("need warm-up cycles >= 0 and measured cycles >= 1")
        if self.temperature_band_c and self.temperature_band_c[0] >= self.temperature_band_c[1]:
            raise ConfigError("temperature band must be LOW,HIGH with LOW < HIGH")

    def points(self) -> list[SweepPoint]:
        """Clicks outer, frequency inner: the adjuster moves as rarely as possible."""
        return [SweepPoint(c, self.gas_clicks, f) for c in self.clicks for f in self.frequencies_hz]

    def remaining(self, done: set[tuple[int, int, float]]) -> list[SweepPoint]:
        return [p for p in self.points() if p.key not in done]
