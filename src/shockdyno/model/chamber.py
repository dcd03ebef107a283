"""The rebound chamber as a state: its pressure and its vapour volume, integrated in time.

The paper's model is algebraic: Δp is the drop that passes the flow demand, q(Δp) = A_q ẋ
(A_q the annulus less the Couette drag area). Where the oil is not rigid, or the chamber
empties below its vapour pressure, Δp has a history. The chamber's volume balance is

    A_q ẋ dt = q(Δp) dt + d[occ(p)] + d[V_vap],     Δp = p_c - p,

where the chamber's oil and air occupy occ(p) = V(x) [α p₀ / p - (1 - α) c_oil p]: free
air of volume fraction α at the charge pressure p₀, isothermal (so 1/β_eff = (1-α) c_oil
+ α p₀/p², Wood's law at the local pressure: the air softens the oil most where the
pressure is lowest), and oil of compressibility c_oil. V(x) = A_r (L + x) is the
chamber's volume, L the spec's oil column. q is the model's own flow law (bleed orifice,
shim stack, leak), the same as the algebraic solve's. The chamber cannot fall below the
release pressure p_v: there vapour (and released air) fills the volume the flow does not,
and must be pushed back into solution before the pressure can build again (the lost
force after reversal of a cavitating damper).

Each step is implicit (backward Euler) and at most 1 ms long (sub-steps between samples
further apart, the motion interpolated linearly), so a fit's 5 ms samples see the state
a 1 kHz recording does: the balance is monotone in Δp, so a safeguarded Newton iteration
finds its one root. The loop is compiled (numba), so a
sweep's hundreds of thousands of samples take milliseconds. With α = c_oil = 0 and no
floor the step is exactly the algebraic solve: the paper's model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from shockdyno.model.shims import ShimStack
from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

MIN_PRESSURE_PA = 1.0  # absolute: air cannot be compressed to nothing nor stretched past it
MAX_NEWTON = 100
PERIODIC_PASSES = 4
MAX_STEP_S = 1.0e-3  # the chamber's own step, whatever the samples' spacing


@dataclass(frozen=True)
class Chamber:
    """What a chamber integration needs beyond the samples."""

    air_fraction: float  # at the charge pressure p₀
    charge_pa: float  # p₀, absolute
    oil_compressibility_per_pa: float
    release_pa: float  # -inf: no floor
    length_m: float  # L: V(x) = A_r (L + x)

    @property
    def rigid(self) -> bool:
        return self.air_fraction == 0.0 and self.oil_compressibility_per_pa == 0.0

    @property
    def inert(self) -> bool:
        """The paper's algebraic model: nothing to integrate."""
        return self.rigid and self.release_pa == -math.inf


def _valve_row(v: ShimStack) -> list[float]:
    return [v.perimeter_m, v.face_area_m2, v.preload_n, v.stiffness_n_per_m, v.max_lift_m]


def integrate(
    spec: DamperSpec,
    chamber: Chamber,
    x: FloatArray,
    v: FloatArray,
    p_c: FloatArray,
    dp_static: FloatArray,
    bleed_compression_m2: FloatArray,
    bleed_rebound_m2: FloatArray,
    k_leak: FloatArray,
    starts: IntArray,
    dt_s: FloatArray,
    periodic: bool,
    carry: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(Δp, vapour volume m³, final state) for every sample, segment by segment.

    A segment starts in the static state (Δp = dp_static, no vapour) unless `carry`
    (single segment: the previous call's final state) is given, or `periodic` (whole
    cycles in their steady state: the state it ends in, found by repeating it).
    """
    valves = np.array([_valve_row(spec.compression_valve), _valve_row(spec.rebound_valve)])
    c = spec.discharge_coefficient * math.sqrt(2.0 / spec.oil_density_kg_m3)
    a_q = spec.annulus_area_m2 - spec.couette_area_m2
    use_carry = carry is not None and starts.size == 1
    cin = np.asarray(carry if use_carry else np.zeros(3), dtype=float)
    floor = chamber.release_pa
    dp, vap, state = _run(
        np.ascontiguousarray(x, dtype=float),
        np.ascontiguousarray(v, dtype=float),
        np.ascontiguousarray(p_c, dtype=float),
        np.ascontiguousarray(dp_static, dtype=float),
        np.ascontiguousarray(bleed_compression_m2, dtype=float),
        np.ascontiguousarray(bleed_rebound_m2, dtype=float),
        np.ascontiguousarray(k_leak, dtype=float),
        np.ascontiguousarray(starts, dtype=np.int64),
        np.ascontiguousarray(dt_s, dtype=float),
        valves,
        c,
        a_q,
        spec.annulus_area_m2,
        chamber.length_m,
        chamber.air_fraction,
        chamber.charge_pa,
        chamber.oil_compressibility_per_pa,
        floor if math.isfinite(floor) else -1.0e300,
        math.isfinite(floor),
        periodic,
        cin,
        use_carry,
    )
    return dp, vap, state


@njit(cache=True)
def _flow(d: float, a_b: float, valve: FloatArray, c: float, k_leak: float) -> tuple[float, float]:
    """q(d) and dq/dd for d >= 0 through one direction's bleed, shim stack and leak."""
    perim, face, preload, stiff, lift_max = valve[0], valve[1], valve[2], valve[3], valve[4]
    lift = (d * face - preload) / stiff
    if lift <= 0.0:
        area, darea = a_b, 0.0
    elif lift >= lift_max:
        area, darea = a_b + perim * lift_max, 0.0
    else:
        area, darea = a_b + perim * lift, perim * face / stiff
    s = math.sqrt(d)
    q = c * area * s + k_leak * d
    slope = c * darea * s + k_leak
    if s > 0.0:
        slope += 0.5 * c * area / s
    elif area > 0.0:
        slope = 1.0e300  # √d: infinitely steep at zero
    return q, slope


@njit(cache=True)
def _signed_flow(
    d: float, a_bc: float, a_bt: float, valves: FloatArray, c: float, k_leak: float
) -> tuple[float, float]:
    if d >= 0.0:
        return _flow(d, a_bc, valves[0], c, k_leak)
    q, slope = _flow(-d, a_bt, valves[1], c, k_leak)
    return -q, slope


@njit(cache=True)
def _occupied(p: float, vol: float, alpha: float, p0: float, c_oil: float) -> tuple[float, float]:
    """Volume the chamber's oil and air take up at pressure p (up to a constant), and its
    derivative (negative: compliance)."""
    pe = max(p, MIN_PRESSURE_PA)
    occ = vol * (alpha * p0 / pe - (1.0 - alpha) * c_oil * p)
    docc = -vol * (alpha * p0 / (pe * pe) + (1.0 - alpha) * c_oil)
    return occ, docc


@njit(cache=True)
def _step(
    d_guess: float,
    p_old: float,
    vap_old: float,
    pc: float,
    q_demand: float,
    dt: float,
    vol: float,
    a_bc: float,
    a_bt: float,
    k_leak: float,
    valves: FloatArray,
    c: float,
    alpha: float,
    p0: float,
    c_oil: float,
    floor: float,
    has_floor: bool,
) -> tuple[float, float]:
    """One backward-Euler step: (Δp, vapour volume) at the step's end.

    H(d) = V_vap,old + dt (Q - q(d)) - occ(p_c - d) + occ(p_old) is the vapour the step
    would leave; it falls strictly with d. Its root is the new Δp unless the pressure
    there is below the floor: then the chamber sits at the floor with H(d_floor) of vapour.
    """
    occ_old, _ = _occupied(p_old, vol, alpha, p0, c_oil)
    compliant = alpha > 0.0 or c_oil > 0.0
    if has_floor:
        d_floor = pc - floor
        q, _ = _signed_flow(d_floor, a_bc, a_bt, valves, c, k_leak)
        occ, _ = _occupied(floor, vol, alpha, p0, c_oil)
        h_floor = vap_old + dt * (q_demand - q) - occ + occ_old
        if h_floor >= 0.0:
            return d_floor, h_floor
        hi = d_floor
    elif alpha > 0.0:
        hi = pc - MIN_PRESSURE_PA
    else:
        hi = math.inf
    # A lower bound (H > 0) and, without a floor, an upper one (H < 0), by doubling.
    width = max(abs(d_guess), 1.0e3)
    lo = min(d_guess, hi) - width
    for _ in range(200):
        q, _ = _signed_flow(lo, a_bc, a_bt, valves, c, k_leak)
        occ, _ = _occupied(pc - lo, vol, alpha, p0, c_oil)
        if vap_old + dt * (q_demand - q) - occ + occ_old > 0.0:
            break
        lo -= width
        width *= 2.0
    if not math.isfinite(hi):
        width = max(abs(d_guess), 1.0e3)
        hi = max(d_guess, lo) + width
        for _ in range(200):
            q, _ = _signed_flow(hi, a_bc, a_bt, valves, c, k_leak)
            occ, _ = _occupied(pc - hi, vol, alpha, p0, c_oil)
            if vap_old + dt * (q_demand - q) - occ + occ_old < 0.0:
                break
            hi += width
            width *= 2.0
    d = min(max(d_guess, lo), hi)
    tol_q = 1.0e-12 * (abs(q_demand) * dt + 1.0e-12) if compliant else 0.0
    for _ in range(MAX_NEWTON):
        q, dq = _signed_flow(d, a_bc, a_bt, valves, c, k_leak)
        occ, docc = _occupied(pc - d, vol, alpha, p0, c_oil)
        h = vap_old + dt * (q_demand - q) - occ + occ_old
        if abs(h) <= tol_q + 1.0e-10 * dt * abs(q_demand) + 1.0e-22:
            break
        if h > 0.0:
            lo = d
        else:
            hi = d
        dh = -dt * dq + docc  # dH/dd: -dt q' - occ'(p)·(-1), both negative
        step = d - h / dh if dh < 0.0 else math.nan
        if not (lo < step < hi) or not math.isfinite(step):
            step = 0.5 * (lo + hi)
        d = step
        if hi - lo <= 1.0e-12 * (abs(d) + 1.0):
            break
    return d, 0.0


@njit(cache=True)
def _run(
    x: FloatArray,
    v: FloatArray,
    p_c: FloatArray,
    dp_static: FloatArray,
    a_bc: FloatArray,
    a_bt: FloatArray,
    k_leak: FloatArray,
    starts: NDArray[np.int64],
    dt_s: FloatArray,
    valves: FloatArray,
    c: float,
    a_q: float,
    a_r: float,
    length: float,
    alpha: float,
    p0: float,
    c_oil: float,
    floor: float,
    has_floor: bool,
    periodic: bool,
    carry: FloatArray,
    use_carry: bool,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    n = x.size
    dp = np.empty(n)
    vap = np.empty(n)
    state = np.zeros(3)
    nseg = starts.size
    for k in range(nseg):
        lo = starts[k]
        hi = starts[k + 1] if k + 1 < nseg else n
        if hi <= lo:
            continue
        dt = dt_s[k]
        if use_carry:
            p, vv, d = carry[0], carry[1], carry[2]
        else:
            p, vv = p_c[lo] - dp_static[lo], 0.0
            if has_floor and p < floor:
                p = floor
            d = p_c[lo] - p
        passes = PERIODIC_PASSES if periodic else 1
        for it in range(passes):
            p_start, v_start = p, vv
            for i in range(lo, hi):
                if i == lo and it == 0 and not use_carry:
                    dp[i] = d  # the initial state is the first sample's
                    vap[i] = vv
                    continue
                # Sub-steps of at most MAX_STEP_S between samples, inputs interpolated
                # linearly: a vapour volume's refill ends within a millisecond, which a
                # fit's 5 ms samples would place a whole step late. The first sample of
                # a periodic pass follows the segment's last; of a carried call, the last
                # call's (inputs held).
                m = max(1, int(math.ceil(dt / MAX_STEP_S - 1e-9)))  # noqa: RUF046 (numba)
                for j in range(1, m + 1):
                    w = j / m
                    k0 = i - 1 if i > lo else (hi - 1 if it > 0 else i)
                    xi = x[k0] + w * (x[i] - x[k0])
                    vi = v[k0] + w * (v[i] - v[k0])
                    pci = p_c[k0] + w * (p_c[i] - p_c[k0])
                    vol = a_r * max(length + xi, 0.05 * length)
                    d, vv = _step(
                        d,
                        p,
                        vv,
                        pci,
                        a_q * vi,
                        dt / m,
                        vol,
                        a_bc[i],
                        a_bt[i],
                        k_leak[i],
                        valves,
                        c,
                        alpha,
                        p0,
                        c_oil,
                        floor,
                        has_floor,
                    )
                    p = pci - d
                dp[i] = d
                vap[i] = vv
            if it + 1 < passes:
                close = abs(p - p_start) <= 1.0e-6 * (abs(p_start) + 1.0e3)
                if close and abs(vv - v_start) <= 1.0e-12:
                    break
        state[0] = p
        state[1] = vv
        state[2] = d  # the next step's first guess: a split run gives the same bits
    return dp, vap, state
