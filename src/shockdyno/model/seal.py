"""The rod seal's friction with its presliding: the force turns with the travel since
reversal, not with the sign of the velocity.

A seal does not slip the instant the rod turns: its lip (or the asperities of its
contact) first deflects, elastically, over a presliding distance δ. In the LuGre form,
integrated along the rod's travel (rate-independent but for the sliding level g(v)):

    dz/dx = (δ_g(v) tanh(v/v_ε) - z) / δ_g(v),   δ_g = δ g(v) / F_c,   F_seal = (F_c / δ) z

so the friction turns over a few δ of travel after each reversal and approaches
g(v) tanh(v/v_ε) while sliding; g = F_c is Coulomb friction, g = F_c + F_b exp(-(v/v_s)²)
a Stribeck breakaway (the `friction` term). Its steady state keeps the paper's smoothed
sign (v_ε, the spec's friction_velocity_m_s), so as δ → 0 the seal becomes the paper's
F_c tanh(v/v_ε) and the term's static map, continuously; at δ = 0 those are used
(model/composite.py). Each step is exact for g held over the step; its path length comes
from the velocity at both ends (a reversal inside a step is split at the velocity's
zero), so 100 Hz and 1 kHz samples reach nearly the same state.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from shockdyno.model.recent import Recent

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def seal_force(
    v: FloatArray,
    starts: IntArray,
    dt_s: FloatArray,
    coulomb_n: float,
    presliding_m: float,
    smoothing_m_s: float,
    periodic: bool,
    breakaway_n: float = 0.0,
    stribeck_m_s: float = 1.0,
    carry: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """(F_seal per sample, final state) for δ > 0, segment by segment: each segment from
    the steady state of its first sample, from `carry` (single segment), or (periodic)
    from the state it ends in."""
    use_carry = carry is not None and starts.size == 1
    z, state = _recent_deflection(
        np.ascontiguousarray(v, dtype=float),
        np.ascontiguousarray(starts, dtype=np.int64),
        np.ascontiguousarray(dt_s, dtype=float),
        coulomb_n,
        breakaway_n,
        stribeck_m_s,
        presliding_m,
        smoothing_m_s,
        periodic,
        np.asarray(carry if use_carry else np.zeros(1), dtype=float),
        use_carry,
    )
    return coulomb_n / presliding_m * z, state


@njit(cache=True, error_model="numpy")
def _load(z: float, target: float, path: float, width: float) -> float:
    """The deflection after `path` of travel toward `target`, the steady width held."""
    return target + (z - target) * math.exp(-path / width)


@njit(cache=True, error_model="numpy")
def _deflection(
    v: FloatArray,
    starts: NDArray[np.int64],
    dt_s: FloatArray,
    f_c: float,
    f_b: float,
    v_s: float,
    delta: float,
    v_eps: float,
    periodic: bool,
    carry: FloatArray,
    use_carry: bool,
) -> tuple[FloatArray, FloatArray]:
    n = v.size
    z_out = np.empty(n)
    state = np.zeros(1)
    ratio = f_b / f_c if f_c > 0.0 else 0.0
    for k in range(starts.size):
        lo = starts[k]
        hi = starts[k + 1] if k + 1 < starts.size else n
        if hi <= lo:
            continue
        dt = dt_s[k]
        if use_carry:
            z = carry[0]
        else:
            z = delta * (1.0 + ratio * math.exp(-((v[lo] / v_s) ** 2))) * math.tanh(v[lo] / v_eps)
        passes = 2 if periodic and not use_carry else 1
        for it in range(passes):
            for i in range(lo, hi):
                if i == lo and it == 0 and not use_carry:
                    z_out[i] = z
                    continue
                # The step into sample i: from the previous sample, or for the first
                # sample of a periodic pass from the segment's last (a carried call's
                # first step holds the velocity).
                j = i - 1 if i > lo else (i if use_carry else hi - 1)
                a, b = v[j], v[i]
                width = delta * (1.0 + ratio * math.exp(-((b / v_s) ** 2)))
                toward_b = width * math.tanh(b / v_eps)
                if a * b < 0.0:
                    phi = a / (a - b)  # the rod turns inside the step: there, then back
                    toward_a = width * math.tanh(a / v_eps)
                    z = _load(z, toward_a, 0.5 * abs(a) * phi * dt, width)
                    z = _load(z, toward_b, 0.5 * abs(b) * (1.0 - phi) * dt, width)
                else:
                    z = _load(z, toward_b, 0.5 * (abs(a) + abs(b)) * dt, width)
                z_out[i] = z
        state[0] = z
    return z_out, state


# A Jacobian column of a parameter that the seal does not read (the gas charge, a valve,
# an area, a chamber's air) repeats the deflection's inputs exactly: on a diagnosis of a
# 15-test held-out sweep the deflection was a fifth of the CPU, recomputed at every column.
_recent_deflection = Recent(_deflection, size=16)
