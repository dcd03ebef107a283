"""Flow through the piston and the pressure drop that passes it (eq. 2-4, 7).

Oil is pushed through the piston at Q = A_r ẋ (the rebound chamber's volume change:
the rod volume goes to the gas piston). Part of it is dragged through the piston-wall gap
by the moving piston (eq. 4's Couette term), the rest needs a pressure drop Δp:

    g(Δp) = C_D (A_b + A_v(Δp)) √(2|Δp|/ρ) + K_leak Δp,

where A_b is the compression or rebound bleed area (eq. 7) and A_v = π d_seat · y the
opening of the shim stack, y = clip((Δp A_face - F_preload) / k, 0, y_max).

g is zero at zero and strictly increasing, so each sample's Δp is unique. We solve for
all samples at once with Newton's method on s = √|Δp| (g is smooth in s: no infinite
slope at the origin), safeguarded by a bracket that every step keeps: a step that would
leave it is replaced by bisection, so the iteration cannot diverge.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shockdyno.model.shims import ShimStack

FloatArray = NDArray[np.float64]

REL_TOL = 1e-10
MAX_ITER = 200
S_MAX = 1e6  # √Pa: 1e12 Pa, far beyond any real damper (hydraulic lock)


def valve_area(dp_pa: FloatArray, valve: ShimStack) -> FloatArray:
    """Flow area of the shim-stack valve at pressure drop dp (>= 0), m²."""
    k = valve.stiffness_n_per_m
    lift = np.clip((dp_pa * valve.face_area_m2 - valve.preload_n) / k, 0.0, valve.max_lift_m)
    return np.asarray(valve.perimeter_m * lift, dtype=float)


def _valve_area_and_slope(s2: FloatArray, valve: ShimStack) -> tuple[FloatArray, FloatArray]:
    k = valve.stiffness_n_per_m
    raw = (s2 * valve.face_area_m2 - valve.preload_n) / k
    opening = (raw > 0) & (raw < valve.max_lift_m)
    area = valve.perimeter_m * np.clip(raw, 0.0, valve.max_lift_m)
    d_area_d_dp = np.where(opening, valve.perimeter_m * valve.face_area_m2 / k, 0.0)
    return area, d_area_d_dp


def passed_flow(
    dp_pa: ArrayLike,
    bleed_area_m2: ArrayLike,
    valve: ShimStack,
    cd: float,
    rho: float,
    k_leak: ArrayLike,
) -> FloatArray:
    """g(Δp) for Δp >= 0 in one direction: the flow the pressure drop drives, m³/s."""
    dp = np.asarray(dp_pa, dtype=float)
    orifice = cd * (np.asarray(bleed_area_m2) + valve_area(dp, valve)) * np.sqrt(2 * dp / rho)
    return np.asarray(orifice + np.asarray(k_leak) * dp, dtype=float)


def solve_pressure_drop(
    q_m3_s: ArrayLike,
    bleed_area_m2: ArrayLike,
    valve: ShimStack,
    cd: float,
    rho: float,
    k_leak: ArrayLike,
) -> FloatArray:
    """Δp >= 0 that passes flow |q| in one direction (all arguments broadcast)."""
    q = np.abs(np.asarray(q_m3_s, dtype=float))
    a_b = np.broadcast_to(np.asarray(bleed_area_m2, dtype=float), q.shape)
    kl = np.broadcast_to(np.asarray(k_leak, dtype=float), q.shape)
    c = cd * math.sqrt(2 / rho)

    def h_and_slope(s: FloatArray) -> tuple[FloatArray, FloatArray]:
        s2 = s * s
        a_v, da = _valve_area_and_slope(s2, valve)
        h = c * (a_b + a_v) * s + kl * s2 - q
        dh = c * (a_b + a_v) + c * s * da * 2 * s + 2 * kl * s
        return h, dh

    # Upper bracket: each path alone needs at least the true Δp, so the bleed-alone and
    # leak-alone drops bound it; so does the drop that passes q with the stack at full lift
    # (or the full-lift pressure, if higher). With every path shut the damper is
    # hydraulically locked: Δp is capped at S_MAX² rather than infinity.
    a_full = a_b + valve.perimeter_m * valve.max_lift_m
    p_full = (valve.stiffness_n_per_m * valve.max_lift_m + valve.preload_n) / valve.face_area_m2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # Test the divisor itself: c·A_b can underflow to 0 for a subnormal area.
        s_bleed = np.where(c * a_b > 0, q / (c * a_b), np.inf)
        s_leak = np.where(kl > 0, np.sqrt(q / kl), np.inf)
        s_valve = np.where(c * a_full > 0, np.maximum(q / (c * a_full), math.sqrt(p_full)), np.inf)
    hi = np.minimum(np.minimum(s_bleed, s_leak), np.minimum(s_valve, S_MAX))
    lo = np.zeros_like(q)
    s = 0.5 * hi
    tol = REL_TOL * q + 1e-18
    for _ in range(MAX_ITER):
        h, dh = h_and_slope(s)
        done = np.abs(h) <= tol
        if np.all(done):
            break
        lo = np.where(h < 0, s, lo)
        hi = np.where(h > 0, s, hi)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            step = s - h / dh  # a non-finite step is caught below and bisected
        bad = ~np.isfinite(step) | (step <= lo) | (step >= hi)
        s = np.where(done, s, np.where(bad, 0.5 * (lo + hi), step))
    return np.asarray(s * s, dtype=float)
