"""ISO 8608 road profiles as sums of harmonics (the paper's eq. 20-23).

The road's one-sided displacement PSD in angular spatial frequency Ω (rad/m) is

    S_g(Ω) = A_g (Ω / Ω0)^(-w),      Ω0 = 1 rad/m, waviness w = 2,           (eq. 23)

with A_g the class's geometric mean (ISO 8608; the paper's Table 6 lists it as 1, 4,
16, 64, 256 for classes A-E, in 10⁻⁶ m³). A road segment of length L is the sum

    z(s) = Σ_n S_n sin(n ΔΩ s + φ_n),   S_n = √(2 S_g(n ΔΩ) ΔΩ),  ΔΩ = 2π / L   (eq. 20-21)

over the harmonics whose Ω_n = n ΔΩ lies in the band [Ω_min, Ω_max]; φ_n is uniform in
[0, 2π). Driven at speed v, harmonic n has angular frequency n ω with ω = 2π v / L (eq. 22).

Phases come from `numpy.random.default_rng(seed)`, one draw per harmonic index n = 1, 2,
..., so the phase of harmonic n depends only on (seed, n): the same seed gives the same
road, and roads of different classes with the same seed have the same shape, scaled by
√(A_g ratio). The profile is periodic in L; `period_samples` uses that to synthesise it
exactly with one inverse FFT.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shockdyno.errors import ConfigError

FloatArray = NDArray[np.float64]

OMEGA0_RAD_M = 1.0
# ISO 8608 geometric-mean PSD at Ω0 = 1 rad/m, m³ (classes F-H for completeness).
ISO8608_CLASSES_M3: dict[str, float] = {c: 1e-6 * 4.0**i for i, c in enumerate("ABCDEFGH")}
# ISO 8608's band, 0.011-2.83 cycles/m, in rad/m.
DEFAULT_BAND_RAD_M = (2 * math.pi * 0.011, 2 * math.pi * 2.83)


def road_psd(omega_rad_m: ArrayLike, a_g_m3: float, waviness: float = 2.0) -> FloatArray:
    """Eq. 23: one-sided displacement PSD S_g(Ω), m³ (m² per rad/m)."""
    om = np.asarray(omega_rad_m, dtype=float)
    return np.asarray(a_g_m3 * (om / OMEGA0_RAD_M) ** (-waviness), dtype=float)


def class_psd(road_class: str) -> float:
    """A_g of an ISO 8608 class letter, m³."""
    try:
        return ISO8608_CLASSES_M3[road_class.strip().upper()]
    except KeyError:
        known = ", ".join(ISO8608_CLASSES_M3)
        raise ConfigError(f"unknown ISO 8608 road class {road_class!r} (known: {known})") from None


@dataclass(frozen=True)
class RoadProfile:
    """A synthesised road segment: harmonics n_first..n_last of ΔΩ = 2π / length_m."""

    length_m: float
    harmonic: NDArray[np.int64]
    amplitude_m: FloatArray
    phase_rad: FloatArray

    @property
    def omega_rad_m(self) -> FloatArray:
        """The spatial angular frequency of each harmonic, Ω = n ΔΩ (rad/m)."""
        return np.asarray(self.harmonic * (2 * math.pi / self.length_m), dtype=float)

    def elevation(self, s_m: ArrayLike) -> FloatArray:
        """z(s) by the direct sum (for checks and for adaptive integrators)."""
        s = np.asarray(s_m, dtype=float)
        arg = np.multiply.outer(s, self.omega_rad_m) + self.phase_rad
        return np.asarray(np.sin(arg) @ self.amplitude_m, dtype=float)

    def period_samples(self, n_samples: int) -> FloatArray:
        """z(s_k), s_k = k L / n_samples, over one period, exactly, by one inverse FFT.

        At speed v these are the road under the tyre at t_k = k T / n_samples, T = L / v.
        """
        if self.harmonic.size and 2 * int(self.harmonic[-1]) >= n_samples:
            raise ConfigError(
                f"time grid too coarse for the road: {n_samples} samples per period cannot "
                f"carry harmonic {int(self.harmonic[-1])} (raise the sample rate or lower "
                "the band's upper limit)"
            )
        spec = np.zeros(n_samples // 2 + 1, dtype=np.complex128)
        # sin(θ + φ) = Re(e^{i(θ + φ - π/2)}); irfft divides by n and folds the conjugate half.
        spec[self.harmonic] = (
            0.5 * n_samples * self.amplitude_m * np.exp(1j * (self.phase_rad - math.pi / 2))
        )
        return np.asarray(np.fft.irfft(spec, n_samples), dtype=float)

    def rms_m(self) -> float:
        """The elevation's RMS over a period (m): √(Σ amplitude² / 2)."""
        return float(np.sqrt(np.sum(self.amplitude_m**2) / 2))


def synthesize_road(
    a_g_m3: float,
    length_m: float,
    band_rad_m: tuple[float, float] = DEFAULT_BAND_RAD_M,
    waviness: float = 2.0,
    seed: int = 0,
) -> RoadProfile:
    """Eq. 20-23: the harmonics of a road of PSD level A_g over a segment of length L."""
    lo, hi = band_rad_m
    if not (math.isfinite(a_g_m3) and a_g_m3 > 0):
        raise ConfigError(f"road PSD level must be > 0, got {a_g_m3}")
    if not (math.isfinite(length_m) and length_m > 0):
        raise ConfigError(f"road length must be > 0, got {length_m} m")
    if not (0 < lo < hi and math.isfinite(hi)):
        raise ConfigError(f"road band must satisfy 0 < Ω_min < Ω_max, got [{lo}, {hi}] rad/m")
    d_omega = 2 * math.pi / length_m
    n_first = max(1, math.ceil(lo / d_omega - 1e-9))
    n_last = math.floor(hi / d_omega + 1e-9)
    if n_last < n_first:
        raise ConfigError(
            f"a {length_m:g} m road has no harmonic in [{lo:g}, {hi:g}] rad/m "
            f"(spacing {d_omega:g} rad/m): lengthen the road or widen the band"
        )
    harmonic = np.arange(n_first, n_last + 1, dtype=np.int64)
    phases = np.random.default_rng(seed).uniform(0.0, 2 * math.pi, n_last)[n_first - 1 :]
    amplitude = np.sqrt(2 * road_psd(harmonic * d_omega, a_g_m3, waviness) * d_omega)
    return RoadProfile(length_m, harmonic, amplitude, phases)
