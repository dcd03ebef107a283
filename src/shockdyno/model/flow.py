"""Flow through the piston and the pressure drop that passes it (eq. 2-4, 7).

Oil is pushed through the piston at Q = A_r ẋ (the rebound chamber's volume change:
the rod volume goes to the gas piston). Part of it is dragged through the piston-wall gap
by the moving piston (eq. 4's Couette term), the rest needs a pressure drop Δp:

    g(Δp) = C_D (A_b + A_v(Δp)) √(2|Δp|/ρ) + K_leak Δp,

where A_b is the compression or rebound bleed area (eq. 7) and A_v = π d_seat · y the
opening of the shim stack, y = clip((Δp A_face - F_preload) / k, 0, y_max). A bleed with a
laminar land (the spec's `bleed_land_m`, L) has its Hagen-Poiseuille resistance λ/A_b²
(λ = 8π μ L) in series with its orifice, Δp = λ q/A_b² + q²/(C_D² A_b² 2/ρ), so its flow is

    q_b(Δp) = 2 A_b² Δp / (λ + √(λ² + 4 A_b² Δp / c²)),   c = C_D √(2/ρ),

which is c A_b √Δp at λ = 0 (computed as such there: the paper's model, bit for bit).

g is zero at zero and strictly increasing, so each sample's Δp is unique. We solve for
all samples at once with Newton's method on s = √|Δp| (g is smooth in s: no infinite
slope at the origin), safeguarded by a bracket that every step keeps: a step that would
leave it is replaced by bisection, so the iteration cannot diverge.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from shockdyno.model.recent import Recent
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


def bleed_flow(dp_pa: ArrayLike, area_m2: ArrayLike, c: float, laminar: ArrayLike) -> FloatArray:
    """q_b(Δp), Δp >= 0, through a bleed of area A with a laminar land λ (module docstring)."""
    dp = np.asarray(dp_pa, dtype=float)
    a = np.asarray(area_m2, dtype=float)
    lam = np.asarray(laminar, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        mixed = 2 * a * a * dp / (lam + np.sqrt(lam * lam + 4 * a * a * dp / (c * c)))
    return np.asarray(np.where(lam > 0, np.nan_to_num(mixed), c * a * np.sqrt(dp)), dtype=float)


def passed_flow(
    dp_pa: ArrayLike,
    bleed_area_m2: ArrayLike,
    valve: ShimStack,
    cd: float,
    rho: float,
    k_leak: ArrayLike,
    laminar: ArrayLike = 0.0,
    valve_laminar: float = 0.0,
) -> FloatArray:
    """g(Δp) for Δp >= 0 in one direction: the flow the pressure drop drives, m³/s;
    `valve_laminar` the stack's seat land λ_v = 12 μ L (0: a sharp-edged opening)."""
    dp = np.asarray(dp_pa, dtype=float)
    c = cd * math.sqrt(2 / rho)
    if valve_laminar > 0:
        v = valve
        flat = np.ravel(dp)
        qv = np.array(
            [
                valve_land_flow(
                    float(d), v.perimeter_m, v.face_area_m2, v.preload_n,
                    v.stiffness_n_per_m, v.max_lift_m, c, valve_laminar,
                )[0]
                for d in flat
            ]
        ).reshape(dp.shape)  # fmt: skip
        q = bleed_flow(dp, bleed_area_m2, c, laminar) + qv
        return np.asarray(q + np.asarray(k_leak) * dp, dtype=float)
    if not np.any(np.asarray(laminar) > 0):
        orifice = cd * (np.asarray(bleed_area_m2) + valve_area(dp, valve)) * np.sqrt(2 * dp / rho)
        return np.asarray(orifice + np.asarray(k_leak) * dp, dtype=float)
    q = bleed_flow(dp, bleed_area_m2, c, laminar) + c * valve_area(dp, valve) * np.sqrt(dp)
    return np.asarray(q + np.asarray(k_leak) * dp, dtype=float)


def solve_pressure_drop(
    q_m3_s: ArrayLike,
    bleed_area_m2: ArrayLike,
    valve: ShimStack,
    cd: float,
    rho: float,
    k_leak: ArrayLike,
    laminar: ArrayLike = 0.0,
    valve_laminar: float = 0.0,
) -> FloatArray:
    """Δp >= 0 that passes flow |q| in one direction (all arguments broadcast); `laminar`
    the bleed's λ = 8π μ L (0: a sharp orifice), `valve_laminar` the stack's seat land's
    λ_v = 12 μ L (0: a sharp-edged opening)."""
    q = np.abs(np.asarray(q_m3_s, dtype=float))
    a_b = np.broadcast_to(np.asarray(bleed_area_m2, dtype=float), q.shape)
    kl = np.broadcast_to(np.asarray(k_leak, dtype=float), q.shape)
    lam = np.broadcast_to(np.asarray(laminar, dtype=float), q.shape)
    s = _recent_solve(
        np.ascontiguousarray(q).ravel(),
        np.ascontiguousarray(a_b).ravel(),
        np.ascontiguousarray(kl).ravel(),
        np.ascontiguousarray(lam).ravel(),
        cd * math.sqrt(2 / rho),
        valve.perimeter_m,
        valve.face_area_m2,
        valve.preload_n,
        valve.stiffness_n_per_m,
        valve.max_lift_m,
        float(valve_laminar),
    )
    return np.asarray((s * s).reshape(q.shape), dtype=float)


@njit(cache=True, error_model="numpy", inline="always")
def laminar_orifice(d: float, a2: float, lam: float, c: float) -> tuple[float, float, float]:
    """q and dq/dd at a drop d >= 0 through an opening of area A (a2 = A²) with a laminar
    passage λ in series (the module docstring's q_b), and D = √(λ² + 4A²d/c²), which a
    caller's other derivatives need: linear (A²d/λ) at zero, orifice-like (c A √d) fast."""
    dd = math.sqrt(lam * lam + 4.0 * a2 * d / (c * c))
    den = lam + dd
    q = 2.0 * a2 * d / den
    return q, (2.0 * a2 * den - 2.0 * a2 * d * (2.0 * a2 / (c * c * dd))) / (den * den), dd


@njit(cache=True, error_model="numpy", inline="always")
def _laminar_orifice_s(s: float, a2: float, lam: float, c: float) -> tuple[float, float]:
    """`laminar_orifice` in s = √d, as the solve iterates: q and dq/ds."""
    s2 = s * s
    dd = math.sqrt(lam * lam + 4.0 * a2 * s2 / (c * c))
    den = lam + dd
    q = 2.0 * a2 * s2 / den
    return q, (4.0 * a2 * s * den - 2.0 * a2 * s2 * (4.0 * a2 * s / (c * c * dd))) / (den * den)


@njit(cache=True, error_model="numpy", inline="always")
def valve_land_flow(
    d: float,
    perim: float,
    face: float,
    preload: float,
    k: float,
    max_lift: float,
    c: float,
    vl: float,
) -> tuple[float, float]:
    """q and dq/dd through a shim stack whose opening (perimeter P, lift y) has a seat land
    λ_v = 12 μ L in series: Δp = (q / (c P y))² + λ_v q / (P y³), so
    q = 2A²d / (Λ + √(Λ² + 4A²d/c²)) with A = P y, Λ = λ_v P / y (the bleed's form at the
    opening's area); 0 while the stack is shut."""
    raw = (d * face - preload) / k
    if raw <= 0.0 or d <= 0.0:
        return 0.0, 0.0
    if raw >= max_lift:
        y, dy = max_lift, 0.0
    else:
        y, dy = raw, face / k
    a = perim * y
    a2 = a * a
    lam = vl * perim / y
    q, dq_dd, dd = laminar_orifice(d, a2, lam, c)
    den = lam + dd
    dq_da = (4.0 * a * d * den - 2.0 * a2 * d * (4.0 * a * d / (c * c * dd))) / (den * den)
    dq_dlam = -2.0 * a2 * d / (dd * den)
    return q, dq_dd + (dq_da * perim - dq_dlam * vl * perim / (y * y)) * dy


# error_model="numpy": a zero slope gives an infinite step (then bisected), not an exception.
@njit(cache=True, error_model="numpy", inline="always")
def _solve_one(
    qi: float,
    ab: float,
    kli: float,
    li: float,
    c: float,
    perim: float,
    face: float,
    preload: float,
    k: float,
    max_lift: float,
    guess: float,
    vl: float = 0.0,
) -> float:
    """s = √Δp that passes flow qi >= 0: Newton inside a bracket each step keeps (module
    docstring), from `guess` where it lies inside the first bracket (a neighbouring
    sample's s: 2-3 iterations where the bracket's middle took 6-10), else its middle."""
    # Upper bracket: each path alone needs at least the true Δp, so the bleed-alone and
    # leak-alone drops bound it; so does the drop that passes q with the stack at full lift
    # (or the full-lift pressure, if higher). With every path shut the damper is
    # hydraulically locked: Δp is capped at S_MAX² rather than infinity.
    p_full = (k * max_lift + preload) / face
    slope_open = perim * face / k
    # Test the divisor itself: c·A_b can underflow to 0 for a subnormal area.
    if li > 0 or vl > 0:
        # A laminar land: the bleed alone passes q at λq/A² + (q/(cA))², and the
        # stack alone (the bleed's share unknown) at full lift, through its seat land's
        # λ_v q/(P y³) as well.
        if li > 0:
            s_bleed = math.sqrt(li * qi / (ab * ab) + (qi / (c * ab)) ** 2) if ab > 0 else math.inf
        else:
            s_bleed = qi / (c * ab) if c * ab > 0 else math.inf
        a_full = perim * max_lift
        lam_full = vl / (perim * max_lift**3) if a_full > 0 else 0.0
        s_valve = (
            max(math.sqrt((qi / (c * a_full)) ** 2 + lam_full * qi), math.sqrt(p_full))
            if c * a_full > 0
            else math.inf
        )
    else:
        s_bleed = qi / (c * ab) if c * ab > 0 else math.inf
        a_full = ab + perim * max_lift
        s_valve = max(qi / (c * a_full), math.sqrt(p_full)) if c * a_full > 0 else math.inf
    s_leak = math.sqrt(qi / kli) if kli > 0 else math.inf
    hi = min(min(s_bleed, s_leak), min(s_valve, S_MAX))
    lo = 0.0
    s = guess if 0.0 < guess < hi else 0.5 * hi
    tol = REL_TOL * qi + 1e-18
    for _ in range(MAX_ITER):
        s2 = s * s
        raw = (s2 * face - preload) / k
        area = perim * min(max(raw, 0.0), max_lift)
        da = slope_open if 0 < raw < max_lift else 0.0
        if vl > 0:
            # The stack through its seat land (`valve_land_flow`), the bleed beside it.
            if li > 0 and ab > 0:
                qb, dqb = _laminar_orifice_s(s, ab * ab, li, c)
            else:
                qb, dqb = c * ab * s, c * ab
            qv, dqv = valve_land_flow(s2, perim, face, preload, k, max_lift, c, vl)
            h = qb + qv + kli * s2 - qi
            if abs(h) <= tol:
                break
            dh = dqb + dqv * 2 * s + 2 * kli * s
        elif li > 0:
            qb, dqb = _laminar_orifice_s(s, ab * ab, li, c)
            h = qb + c * area * s + kli * s2 - qi
            if abs(h) <= tol:
                break
            dh = dqb + c * area + c * s * da * 2 * s + 2 * kli * s
        else:
            h = c * (ab + area) * s + kli * s2 - qi
            if abs(h) <= tol:
                break
            dh = c * (ab + area) + c * s * da * 2 * s + 2 * kli * s
        if h < 0:
            lo = s
        if h > 0:
            hi = s
        step = s - h / dh  # a non-finite step is caught below and bisected
        bad = not math.isfinite(step) or step <= lo or step >= hi
        s = 0.5 * (lo + hi) if bad else step
    return s


@njit(cache=True, error_model="numpy")
def _solve_s(
    q: FloatArray,
    a_b: FloatArray,
    kl: FloatArray,
    lam: FloatArray,
    c: float,
    perim: float,
    face: float,
    preload: float,
    k: float,
    max_lift: float,
    vl: float,
) -> FloatArray:
    """s = √Δp per sample, one direction's valve (seat land λ_v = vl)."""
    out = np.empty(q.size)
    s = 0.0
    for i in range(q.size):
        s = _solve_one(q[i], a_b[i], kl[i], lam[i], c, perim, face, preload, k, max_lift, s, vl)
        out[i] = s
    return out


@njit(cache=True, error_model="numpy")
def _solve_signed(
    q: FloatArray,
    a_bc: FloatArray,
    a_bt: FloatArray,
    kl: FloatArray,
    lam: FloatArray,
    c: float,
    valves: FloatArray,
    first: NDArray[np.bool_],
    vlam: FloatArray,
) -> FloatArray:
    """Δp per sample through the valve of its flow's direction (rows of `valves`:
    perimeter, face area, preload, stiffness, lift; compression's then rebound's); 0
    where nothing flows. Each sample's Newton starts from the one before's root where
    that flowed the same way in the same segment (`first`: a segment's first sample), so
    a test's numbers do not depend on the test before it."""
    out = np.zeros(q.size)
    s = 0.0  # the sample before's s (0: none, or the other direction's)
    for i in range(q.size):
        qi = q[i]
        if first[i]:
            s = 0.0
        if qi > 0:
            vc = valves[0]
            guess = s if i > 0 and q[i - 1] > 0 else 0.0
            s = _solve_one(
                qi, a_bc[i], kl[i], lam[i], c, vc[0], vc[1], vc[2], vc[3], vc[4], guess, vlam[i]
            )
            out[i] = s * s
        elif qi < 0:
            vr = valves[1]
            guess = s if i > 0 and q[i - 1] < 0 else 0.0
            s = _solve_one(
                -qi, a_bt[i], kl[i], lam[i], c, vr[0], vr[1], vr[2], vr[3], vr[4], guess, vlam[i]
            )
            out[i] = -(s * s)
        else:
            s = 0.0
    return out


def solve_signed_drop(
    q_m3_s: FloatArray,
    bleed_compression_m2: FloatArray,
    bleed_rebound_m2: FloatArray,
    compression: ShimStack,
    rebound: ShimStack,
    cd: float,
    rho: float,
    k_leak: FloatArray,
    laminar: FloatArray,
    starts: NDArray[np.intp] | None = None,
    valve_laminar: FloatArray | None = None,
) -> FloatArray:
    """Δp per sample (signed as q: compression positive) for flows of either sign, each
    through its own direction's bleed and valve; per-sample arrays of q's size, in
    segments from `starts` (default one); `valve_laminar` the stacks' seat land λ_v per
    sample (None: sharp-edged openings). The same as `solve_pressure_drop` on each
    direction's samples apart, in one pass (no masks)."""
    first = np.zeros(np.shape(q_m3_s), dtype=bool)
    first[np.asarray(starts if starts is not None else [0], dtype=np.intp)] = True
    valves = np.array(
        [
            [v.perimeter_m, v.face_area_m2, v.preload_n, v.stiffness_n_per_m, v.max_lift_m]
            for v in (compression, rebound)
        ]
    )
    return np.asarray(
        _recent_signed(
            np.ascontiguousarray(q_m3_s, dtype=float),
            np.ascontiguousarray(bleed_compression_m2, dtype=float),
            np.ascontiguousarray(bleed_rebound_m2, dtype=float),
            np.ascontiguousarray(k_leak, dtype=float),
            np.ascontiguousarray(laminar, dtype=float),
            cd * math.sqrt(2 / rho),
            valves,
            first,
            np.zeros(np.shape(q_m3_s))
            if valve_laminar is None
            else np.ascontiguousarray(valve_laminar, dtype=float),
        ),
        dtype=float,
    )


# A Jacobian column of a parameter that acts after the flow solve repeats its inputs exactly
# (friction + air: 12456 of 19676 solves repeated one of the last 8, 12664 of the last 16).
_recent_solve = Recent(_solve_s, size=16)
_recent_signed = Recent(_solve_signed, size=16)
