"""Causal filters that physics and sensor terms share, segment by segment.

Every filter runs on each segment (one test) on its own, starting from steady state, so
state never leaks from one test into the next. A single-segment call can carry its
final state into the next call (the simulated rig computes a record in chunks), and any
split of one record then gives the same numbers as one call.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def segment_bounds(starts: IntArray, n: int) -> list[tuple[int, int]]:
    """(first, end) sample index of each segment, from the segments' `starts` and the sample
    count `n`."""
    ends = [*(int(s) for s in starts[1:]), n]
    return [(int(s), e) for s, e in zip(starts, ends, strict=True)]


@njit(cache=True, error_model="numpy")
def lag_coefficients(tau_s: float, dt_s: float) -> tuple[float, float, float]:
    """(b0, b1, e) of a first-order lag τ dy/dt = u - y, exact for u linear between samples.

    y[n] = e y[n-1] + b0 u[n] + b1 u[n-1]. A first-order hold keeps the filter accurate
    at the fit's decimated rate (5 ms steps against lags of a few ms), where holding u
    constant over a step would add a delay of half a step.
    """
    if not tau_s > 0:
        return 1.0, 0.0, 0.0
    e = math.exp(-dt_s / tau_s)
    g = tau_s / dt_s * (1.0 - e)
    b0 = 1.0 - g
    return b0, g - e, e


def first_order_lag(
    u: FloatArray,
    tau_s: float | Sequence[float] | FloatArray,
    starts: IntArray,
    dt_s: FloatArray,
    carry: FloatArray | None = None,
    periodic: bool = False,
    from_rest: bool = False,
) -> tuple[FloatArray, FloatArray | None]:
    """Lag u by τ (per segment, or one τ for all) in every segment; (y, final state).

    A segment starts at steady state (y = u at its first sample) unless `carry` is given,
    which only a single-segment call may pass, or `from_rest` (y = 0 before it).
    `periodic`: each segment is whole cycles of a motion already in its periodic steady
    state (a sweep's measured cycles, after warm-up), so it starts in the state it ends
    in (exact, by superposition); starting
    at y = u instead would add a transient of a few τ to every test.
    """
    taus = np.broadcast_to(np.asarray(tau_s, dtype=float), (starts.size,))
    if starts.size == u.size and carry is None and not from_rest:  # one sample each
        return u.copy(), None
    use_carry = carry is not None and starts.size == 1
    mode = CARRY if use_carry else PERIODIC if periodic else FROM_REST if from_rest else STEADY
    y = np.empty(u.size)
    zf = np.zeros(1)
    seen = _lag_segments(
        np.ascontiguousarray(u, dtype=float),
        np.ascontiguousarray(taus, dtype=float),
        np.ascontiguousarray(starts, dtype=np.int64),
        np.ascontiguousarray(dt_s, dtype=float),
        mode,
        float(np.asarray(carry, dtype=float).reshape(-1)[0]) if use_carry else 0.0,
        y,
        zf,
    )
    return y, (zf if seen else None)


STEADY, PERIODIC, FROM_REST, CARRY = 0, 1, 2, 3  # how a segment of `first_order_lag` starts


@njit(cache=True, error_model="numpy")
def _lag_segments(
    u: FloatArray,
    taus: FloatArray,
    starts: NDArray[np.int64],
    dt_s: FloatArray,
    mode: int,
    carry: float,
    y: FloatArray,
    zf: FloatArray,
) -> bool:
    """`first_order_lag`'s segments in one pass: y, and the last segment's final state in
    zf[0]; whether there was a segment. The same arithmetic as lfilter's transposed
    direct form II, segment by segment (tests/model/test_filters_without_scipy_signal.py)."""
    n = u.size
    seen = False
    for k in range(starts.size):
        lo = starts[k]
        hi = starts[k + 1] if k + 1 < starts.size else n
        seen = True
        b0, b1, e = lag_coefficients(taus[k], dt_s[k])
        if e == 0.0 and b1 == 0.0:
            for i in range(lo, hi):
                y[i] = u[i]
            zf[0] = 0.0
            continue
        if mode == PERIODIC and hi > lo:
            # y = y₀ + z eⁿ for initial state z (y₀: from rest); periodic: z_end(z) = z.
            z = _lag_run(b0, b1, e, u, lo, hi, 0.0, y) / (1.0 - e ** (hi - lo))
            decay = 1.0  # e^(i - lo), by products (a power at every sample took 9x the filter)
            for i in range(lo, hi):
                y[i] = y[i] + z * decay
                decay *= e
            zf[0] = z
            continue
        if mode == CARRY:
            z = carry
        elif mode == FROM_REST or hi <= lo:  # y = 0 before the segment
            z = 0.0
        else:
            z = (b1 + e) * u[lo]
        zf[0] = _lag_run(b0, b1, e, u, lo, hi, z, y)
    return seen


@njit(cache=True, error_model="numpy")
def _lag_run(
    b0: float, b1: float, e: float, u: FloatArray, lo: int, hi: int, z: float, y: FloatArray
) -> float:
    """y[lo:hi] of lfilter([b0, b1], [1, -e], u[lo:hi], zi=[z]), its transposed direct form
    II term for term; the final state."""
    for i in range(lo, hi):
        out = b0 * u[i] + z
        z = b1 * u[i] + e * out
        y[i] = out
    return z


def biquad(
    b: FloatArray, a: FloatArray, u: FloatArray, zi: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """scipy.signal.lfilter(b, a, u, zi) for a second-order section with a[0] = 1:
    (y, final state), compiled (importing scipy.signal takes a second or two at every
    start of a command)."""
    y = np.empty(u.size)
    zf = np.array(zi, dtype=float)
    u = np.ascontiguousarray(u, dtype=float)
    _biquad(float(b[0]), float(b[1]), float(b[2]), float(a[1]), float(a[2]), u, zf, y)
    return y, zf


@njit(cache=True, error_model="numpy")
def _biquad(
    b0: float,
    b1: float,
    b2: float,
    a1: float,
    a2: float,
    u: FloatArray,
    z: FloatArray,
    y: FloatArray,
) -> None:
    # lfilter's transposed direct form II, term for term; z is updated in place.
    z0, z1 = z[0], z[1]
    for n in range(u.size):
        out = b0 * u[n] + z0
        z0 = b1 * u[n] - a1 * out + z1
        z1 = b2 * u[n] - a2 * out
        y[n] = out
    z[0], z[1] = z0, z1


def delayed(
    values: FloatArray,
    slope: FloatArray,
    delay_s: float,
    starts: IntArray,
    dt_s: FloatArray,
) -> FloatArray:
    """values(t - delay) within each segment, by linear interpolation between samples.

    The motion is smooth on the sample scale, so interpolation is accurate for any delay
    (unlike the first-order shift x - δ v, off by δ²a/2 at tens of ms). Before a segment's
    first sample (or after its last) the value is extended along `slope`.

    Compiled, one pass: a plain fit's Jacobian delays a sweep's sixty-odd tests some two
    thousand times, and a loop of np.interp over them was 40 % of its profile. Each
    sample's arithmetic is np.interp's on the segment's own index grid (slope · (pos - j) +
    y_j, y_j itself where pos falls on a sample), so the result is the loop's bit for bit
    (tests/model/test_delayed.py keeps the loop to compare).
    """
    if delay_s == 0.0:
        return values
    if values.size == 0 or not np.all(np.isfinite(values)):
        return _delayed_by_segment(values, slope, delay_s, starts, dt_s)
    out = np.empty(values.shape)
    _delay(
        np.ascontiguousarray(values, dtype=float),
        np.ascontiguousarray(slope, dtype=float),
        float(delay_s),
        np.ascontiguousarray(starts, dtype=np.int64),
        np.ascontiguousarray(dt_s, dtype=float),
        out,
    )
    return out


@njit(cache=True, error_model="numpy")
def _delay(
    values: FloatArray,
    slope: FloatArray,
    delay_s: float,
    starts: NDArray[np.int64],
    dt_s: FloatArray,
    out: FloatArray,
) -> None:
    """`delayed`'s samples: np.interp's arithmetic on each segment's index grid."""
    nseg = starts.size
    for k in range(nseg):
        lo = starts[k]
        hi = starts[k + 1] if k + 1 < nseg else values.size
        n = hi - lo
        dt = dt_s[k]
        c = delay_s / dt
        for i in range(n):
            pos = i - c
            if pos < 0:
                out[lo + i] = values[lo] + pos * dt * slope[lo]
            elif pos > n - 1:
                out[lo + i] = values[hi - 1] + (pos - (n - 1)) * dt * slope[hi - 1]
            elif pos == n - 1:
                out[lo + i] = values[hi - 1]
            else:
                j = int(pos)  # pos >= 0: its floor
                y0 = values[lo + j]
                if pos == j:
                    out[lo + i] = y0
                else:
                    out[lo + i] = (values[lo + j + 1] - y0) * (pos - j) + y0


def _delayed_by_segment(
    values: FloatArray,
    slope: FloatArray,
    delay_s: float,
    starts: IntArray,
    dt_s: FloatArray,
) -> FloatArray:
    """`delayed` one segment at a time, with np.interp (values that are not all finite:
    np.interp's care with infinities)."""
    out = np.empty_like(values)
    for k, (lo, hi) in enumerate(segment_bounds(starts, values.size)):
        n = hi - lo
        dt = float(dt_s[k])
        pos = np.arange(n) - delay_s / dt
        seg = values[lo:hi]
        res = np.interp(pos, np.arange(n), seg)
        before, after = pos < 0, pos > n - 1
        if np.any(before):
            res[before] = seg[0] + pos[before] * dt * slope[lo]
        if np.any(after):
            res[after] = seg[-1] + (pos[after] - (n - 1)) * dt * slope[hi - 1]
        out[lo:hi] = res
    return out
