"""Velocity and acceleration from a measured displacement.

The paper differentiates displacement. A finite difference multiplies sensor noise by
1/dt (an LVDT with 5 µm of noise gives ~7 mm/s of velocity noise at 1 kHz, and ~10 m/s²
of acceleration noise), so we use a Savitzky–Golay filter instead: a cubic fitted by
least squares over a sliding window, differentiated analytically. The window is a fixed
span of time (25 ms by default), so 1 kHz and 300 Hz data get the same smoothing; that
span is short against the fastest dyno cycle (1.5 Hz: 667 ms), so the filter's
amplitude error on a sine is below 0.1 %.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from shockdyno.errors import ConfigError

FloatArray = NDArray[np.float64]

DEFAULT_WINDOW_S = 0.025
POLYORDER = 3


def sample_interval(t: FloatArray, rtol: float = 0.01) -> float:
    """The uniform sampling interval of t; refuses a time base that is not uniform."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ConfigError("a time series needs at least two samples")
    steps = np.diff(t)
    dt = float(np.median(steps))
    if not dt > 0:
        raise ConfigError("time must increase")
    if np.max(np.abs(steps - dt)) > rtol * dt + 1e-12:
        raise ConfigError("time base is not uniform (resample the data first)")
    return dt


def _window(n: int, dt: float, window_s: float) -> int:
    w = round(window_s / dt)
    w = max(w, POLYORDER + 2)
    w += 1 - w % 2  # odd
    return min(w, n if n % 2 else n - 1)


def differentiate(
    t: FloatArray, x: FloatArray, window_s: float = DEFAULT_WINDOW_S
) -> tuple[FloatArray, FloatArray]:
    """(velocity, acceleration) of displacement x sampled at uniform times t."""
    x = np.asarray(x, dtype=float)
    dt = sample_interval(t)
    w = _window(x.size, dt, window_s)
    if w <= POLYORDER:
        # Too few samples for the filter: plain central differences.
        v = np.gradient(x, dt)
        return v, np.gradient(v, dt)
    v = savgol(x, w, POLYORDER, deriv=1, delta=dt)
    a = savgol(x, w, POLYORDER, deriv=2, delta=dt)
    return v, a


def savgol(x: FloatArray, window: int, order: int, deriv: int, delta: float) -> FloatArray:
    """scipy.signal.savgol_filter(x, window, order, deriv, delta, mode="interp"), in numpy:
    importing scipy.signal takes a second or two at every start of a command.

    Inside, each sample is the least-squares polynomial's derivative at the window's
    centre; within half a window of either end, the polynomial fitted to the first (last)
    whole window, evaluated where the sample is."""
    half = window // 2
    pos = np.arange(-half, window - half, dtype=float)
    powers = pos[None, :] ** np.arange(order + 1)[:, None]
    target = np.zeros(order + 1)
    target[deriv] = math.factorial(deriv) / delta**deriv
    coeffs = np.linalg.lstsq(powers, target, rcond=None)[0]
    y = np.convolve(x, coeffs[::-1], mode="same")
    t = np.arange(window, dtype=float)
    for lo, at in ((0, slice(0, half)), (x.size - window, slice(window - half, window))):
        poly = np.polynomial.polynomial.polyfit(t, x[lo : lo + window], order)
        d = np.polynomial.polynomial.polyder(poly, deriv) / delta**deriv
        y[lo + at.start : lo + at.stop] = np.polynomial.polynomial.polyval(t[at], d)
    return np.asarray(y, dtype=float)


def velocity(t: FloatArray, x: FloatArray) -> FloatArray:
    """v = dx/dt with the model's differentiator, also across gaps left by dropped frames.

    NaN everywhere when t does not increase from sample to sample.

    ``differentiate`` needs a uniform time base. A few dropped frames break that, so the
    record is interpolated onto the uniform grid, differentiated there, and the velocity is
    read back at the original times (the gap is bridged linearly, which only matters in it).
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if t.size < 3:
        return np.full(t.size, np.nan)
    try:
        return differentiate(t, x)[0]
    except ConfigError:
        steps = np.diff(t)
        if not np.all(steps > 0):
            # Repeated or reversed time stamps: no velocity rather than a wrong one.
            return np.full(t.size, np.nan)
        dt = float(np.median(steps))
        n = round(float(t[-1] - t[0]) / dt) + 1
        grid = t[0] + dt * np.arange(n)
        v_grid = differentiate(grid, np.interp(grid, t, x))[0]
        return np.interp(t, grid, v_grid)
