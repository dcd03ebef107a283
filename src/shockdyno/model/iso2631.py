"""ISO 2631-1 frequency weighting Wk (vertical whole-body vibration, seated).

Wk is the product of four analogue filters (ISO 2631-1:1997, Annex A):

    band limit   H_h = s² / (s² + ω1 s / Q1 + ω1²)        ω1 = 2π·0.4 Hz, Q1 = 1/√2
                 H_l = ω2² / (s² + ω2 s / Q1 + ω2²)       ω2 = 2π·100 Hz
    a-v trans.   H_t = (1 + s/ω3) / (1 + s/(Q4 ω4) + s²/ω4²)          f3 = f4 = 12.5 Hz, Q4 = 0.63
    upward step  H_s = (1 + s/(Q5 ω5) + s²/ω5²) / (1 + s/(Q6 ω6) + s²/ω6²) · (ω5/ω6)²
                                                           f5 = 2.37, f6 = 3.35 Hz, Q5 = Q6 = 0.91

The weighted RMS is taken in the frequency domain (the gain applied to each DFT line),
which is exact for a record that holds whole periods of a periodic signal, as the ride
study's records do (see ride/study.py).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

F1_HZ, F2_HZ, F3_HZ, F4_HZ, F5_HZ, F6_HZ = 0.4, 100.0, 12.5, 12.5, 2.37, 3.35
Q1, Q4, Q5, Q6 = 1 / math.sqrt(2), 0.63, 0.91, 0.91


def wk_response(f_hz: ArrayLike) -> NDArray[np.complex128]:
    """Complex frequency response of Wk at f (Hz)."""
    s = 2j * np.pi * np.asarray(f_hz, dtype=float)
    w1, w2, w3, w4, w5, w6 = (2 * math.pi * f for f in (F1_HZ, F2_HZ, F3_HZ, F4_HZ, F5_HZ, F6_HZ))
    h_h = s**2 / (s**2 + w1 * s / Q1 + w1**2)
    h_l = w2**2 / (s**2 + w2 * s / Q1 + w2**2)
    h_t = (1 + s / w3) / (1 + s / (Q4 * w4) + s**2 / w4**2)
    h_s = (1 + s / (Q5 * w5) + s**2 / w5**2) / (1 + s / (Q6 * w6) + s**2 / w6**2) * (w5 / w6) ** 2
    return np.asarray(h_h * h_l * h_t * h_s, dtype=np.complex128)


def wk_gain(f_hz: ArrayLike) -> FloatArray:
    """|Wk(f)|: 0.482 at 1 Hz, about 1.05 at 6.3 Hz (ISO 2631-1 Table 3)."""
    return np.asarray(np.abs(wk_response(f_hz)), dtype=float)


def weighted_rms(signal: ArrayLike, dt_s: float, axis: int = -1) -> FloatArray:
    """RMS of the Wk-weighted signal, weighting each DFT line of the record.

    The mean is removed first (Wk's gain at 0 Hz is 0 anyway).
    """
    x = np.asarray(signal, dtype=float)
    n = x.shape[axis]
    spec = np.fft.rfft(x, axis=axis)
    f = np.fft.rfftfreq(n, dt_s)
    shape = [1] * x.ndim
    shape[axis] = f.size
    power = np.abs(spec) ** 2 * wk_gain(f).reshape(shape) ** 2
    # One-sided: every line except DC (and Nyquist for even n) stands for two.
    weights = np.full(f.size, 2.0)
    weights[0] = 0.0
    if n % 2 == 0:
        weights[-1] = 1.0
    total = np.sum(power * weights.reshape(shape), axis=axis)
    return np.asarray(np.sqrt(total) / n, dtype=float)
