"""The reference plant's compiled step (simrig/reference.py holds the physics in words).

One implicit step of h per sub-sample: the rebound-chamber pressure and the gas piston's
travel are the unknowns, each found by a bracketed regula falsi (Illinois) on its own
volume balance, which falls strictly as its unknown rises, and the two balances are
iterated to a common solution (Gauss-Seidel: the gas is soft, so two to four sweeps).
Oil mass moves between the chambers, so it is conserved to round-off whatever the
tolerances. The slow states (heat, released gas) and the rod seal and bump stop, which
do not act on the oil, follow once the pressures are found; the sensor chain filters
every sub-sample and is read once a sample.

Nothing here is imported from the model package: the numbers come in an array `k`
built by reference.py, the state in an array `s`, both indexed by the names below.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

P_ATM = 101_325.0
KELVIN = 273.15
TAIT_C = 0.0894  # the Tait equation's universal constant (liquids, incl. mineral oils)
P_AIR_MIN = 200.0  # Pa: below it the air's volume is extended linearly (a bracket's far end)
P_RATE_REG = 50.0  # Pa: rounds the bubble wall's √Δp law at Δp = 0
GAS_LIMIT = 0.05  # the gas column never shrinks below this share (a bracket's far end)

# -- constants (k) ----------------------------------------------------------------------
_K_NAMES = (
    "H",  # sub-step, s
    "A_P", "A_A", "A_ROD", "A_G", "L_COL", "M_ROD",
    "RHO", "V0", "TAIT_B", "W_AIR", "KAPPA", "P0",
    "VG0", "T_FILL", "GAMMA", "TAU_G", "COUPLING",
    "P_V", "N_B", "V_N", "C_NUC", "U_DES", "TAU_RES",
    "CD", "NEEDLE_LAND", "VALVE_LAND", "TAU_OPEN", "TAU_CLOSE", "LEAK_G",
    "K0_C", "DISH_C", "T_C", "YMAX_C", "FACE_C", "PERIM_C",
    "K0_R", "DISH_R", "T_R", "YMAX_R", "FACE_R", "PERIM_R",
    "PROG", "STOP",
    "MU40", "WALTHER", "WA", "WB",
    "FC", "FB", "VS", "SIG0", "ZBA", "LIP",
    "XB", "F10", "LB", "KM", "TAU_M",
    "C_O", "C_B", "G_OB", "H_CONV", "HEAT",
    "LC_B0", "LC_B1", "LC_B2", "LC_A1", "LC_A2",
    "AA0_B0", "AA0_B1", "AA0_B2", "AA0_A1", "AA0_A2",
    "AA1_B0", "AA1_B1", "AA1_B2", "AA1_A1", "AA1_A2",
    "SKEW",  # force channel's skew in sub-steps
)  # fmt: skip
K = {name: i for i, name in enumerate(_K_NAMES)}
NK = len(_K_NAMES)
# per-run flow paths of the clicks: (area, slit gap) of compression needle, rebound needle,
# and the gas selector's parallel jet
F_AC, F_GC, F_AR, F_GR, F_AJ, F_GJ, F_AMB = range(7)
NF = 7

# -- state (s) --------------------------------------------------------------------------
_S_NAMES = (
    "PR", "PK", "YG", "TG", "MR", "MK", "VC", "NG", "LC", "LR", "Z", "FM",
    "TO", "TB", "X", "V", "FORCE",
    "LC_Z1", "LC_Z2",
    "FAA0_Z1", "FAA0_Z2", "FAA1_Z1", "FAA1_Z2",
    "XAA0_Z1", "XAA0_Z2", "XAA1_Z1", "XAA1_Z2",
    "RING_AT",  # where the next filtered force sub-sample goes in the ring
)  # fmt: skip
S = {name: i for i, name in enumerate(_S_NAMES)}
NS = len(_S_NAMES)

# the constants as module-level integers, which numba compiles in
(
    H, A_P, A_A, A_ROD, A_G, L_COL, M_ROD, RHO, V0, TAIT_B, W_AIR, KAPPA, P0,
    VG0, T_FILL, GAMMA, TAU_G, COUPLING, P_V, N_B, V_N, C_NUC, U_DES, TAU_RES,
    CD, NEEDLE_LAND, VALVE_LAND, TAU_OPEN, TAU_CLOSE, LEAK_G,
    K0_C, DISH_C, T_C, YMAX_C, FACE_C, PERIM_C, K0_R, DISH_R, T_R, YMAX_R, FACE_R, PERIM_R,
    PROG, STOP, MU40, WALTHER, WA, WB, FC, FB, VS, SIG0, ZBA, LIP,
    XB, F10, LB, KM, TAU_M, C_O, C_B, G_OB, H_CONV, HEAT,
    LC_B0, LC_B1, LC_B2, LC_A1, LC_A2,
    AA0_B0, AA0_B1, AA0_B2, AA0_A1, AA0_A2, AA1_B0, AA1_B1, AA1_B2, AA1_A1, AA1_A2, SKEW,
) = range(NK)  # fmt: skip
(
    PR, PK, YG, TG, MR, MK, VC, NG, LC, LR, Z, FM, TO, TB, X, V, FORCE,
    LC_Z1, LC_Z2, FAA0_Z1, FAA0_Z2, FAA1_Z1, FAA1_Z2, XAA0_Z1, XAA0_Z2, XAA1_Z1, XAA1_Z2,
    RING_AT,
) = range(NS)  # fmt: skip


# -- oil, air, viscosity ----------------------------------------------------------------
@njit(cache=True, nogil=True)
def specific_volume(k: FloatArray, p: float) -> float:
    """m³/kg of the oil with its entrained air at absolute pressure p: the Tait liquid,
    v0 (1 - C ln(1 + (p - p_atm)/B)), and the air mixed in it (w_air m³/kg at the
    charge, polytropic with the bubbles' own index)."""
    arg = 1.0 + (p - P_ATM) / k[TAIT_B]
    if arg < 0.05:
        arg = 0.05
    v = k[V0] * (1.0 - TAIT_C * math.log(arg))
    if k[W_AIR] > 0.0:
        inv = 1.0 / k[KAPPA]
        if p >= P_AIR_MIN:
            v += k[W_AIR] * (k[P0] / p) ** inv
        else:  # continued with the slope at P_AIR_MIN: still falling, finite
            at = k[W_AIR] * (k[P0] / P_AIR_MIN) ** inv
            v += at + at * inv / P_AIR_MIN * (P_AIR_MIN - p)
    return float(v)


@njit(cache=True, nogil=True)
def viscosity(k: FloatArray, t_c: float) -> float:
    """Pa·s at t_c °C: the spec's value held, or Walther's (ASTM D341) line through two
    points, log log(ν + 0.7) = A - B log T."""
    if k[WALTHER] == 0.0:
        return float(k[MU40])
    y = k[WA] - k[WB] * math.log10(t_c + KELVIN)
    nu = 10.0 ** (10.0**y) - 0.7
    if nu < 0.5:
        nu = 0.5
    return float(nu * 1e-6 * k[RHO])


# -- flow paths -------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def passage(dp: float, area: float, gap: float, land: float, k: FloatArray, mu: float) -> float:
    """Flow (>= 0) through a slit-like passage at pressure drop dp >= 0: an orifice whose
    discharge coefficient follows the flow number λ = (D_h/ν) √(2Δp/ρ),
    C_d = C_d∞ tanh(2λ/λ_c) (Borutzky, Barnard & Thoma 2002), λ_c set so that the
    laminar limit is the slit's Poiseuille flow, π d g³ Δp / (12 μ ℓ)."""
    if area <= 0.0 or dp <= 0.0:
        return 0.0
    u = math.sqrt(2.0 * dp / k[RHO])
    cd = k[CD]
    if land > 0.0 and gap > 0.0:
        lam = 2.0 * gap * k[RHO] / mu * u
        lam_c = 96.0 * cd * land / gap
        cd = cd * math.tanh(2.0 * lam / lam_c)
    return float(cd * area * u)


@njit(cache=True, nogil=True)
def stack_force(
    y: float, k0: float, dish: float, thick: float, ymax: float, k: FloatArray
) -> float:
    """The shim stack's spring force at lift y: a wedge beam pre-bent by the dish,
    stiffening as its deflection grows (F = k0 s (1 + c (s/t)²), s = dish + y), and a
    backing shim past ymax."""
    s = dish + y
    f = k0 * s * (1.0 + k[PROG] * (s / thick) ** 2)
    if y > ymax:
        f += k[STOP] * k0 * (y - ymax)
    return float(f)


@njit(cache=True, nogil=True)
def static_lift(
    dp: float, k0: float, dish: float, thick: float, ymax: float, face: float, k: FloatArray
) -> float:
    """Lift at which the stack's spring holds dp on its face (0 below the crack)."""
    push = dp * face
    if push <= stack_force(0.0, k0, dish, thick, ymax, k):
        return 0.0
    lo, hi = 0.0, ymax
    while stack_force(hi, k0, dish, thick, ymax, k) < push:
        lo = hi
        hi *= 2.0
    y = 0.5 * (lo + hi)
    for _ in range(60):
        f = stack_force(y, k0, dish, thick, ymax, k) - push
        if f > 0.0:
            hi = y
        else:
            lo = y
        s = dish + y
        df = k0 * (1.0 + 3.0 * k[PROG] * (s / thick) ** 2)
        if y > ymax:
            df += k[STOP] * k0
        yn = y - f / df
        if not lo < yn < hi:
            yn = 0.5 * (lo + hi)
        if abs(yn - y) < 1e-13:
            return float(yn)
        y = yn
    return y


@njit(cache=True, nogil=True)
def _lift(y: float, target: float, k: FloatArray) -> float:
    """The stack's lift after one step towards its static lift: it opens in TAU_OPEN and
    closes in TAU_CLOSE (backward Euler)."""
    tau = k[TAU_OPEN] if target > y else k[TAU_CLOSE]
    r = k[H] / tau
    return float((y + r * target) / (1.0 + r))


@njit(cache=True, nogil=True)
def flow(
    dp: float, s: FloatArray, k: FloatArray, f: FloatArray, mu: float
) -> tuple[float, float, float]:
    """(q, lift_c, lift_r): the volume flow from the compression to the rebound chamber
    at dp = p_k - p_r, and each stack's lift after the step."""
    d = abs(dp)
    if dp > 0.0:
        bleed = passage(d, f[F_AC], f[F_GC], k[NEEDLE_LAND], k, mu)
        yc = _lift(s[LC], static_lift(d, k[K0_C], k[DISH_C], k[T_C], k[YMAX_C], k[FACE_C], k), k)
        yr = _lift(s[LR], 0.0, k)
    else:
        bleed = passage(d, f[F_AR], f[F_GR], k[NEEDLE_LAND], k, mu)
        bleed += passage(d, f[F_AJ], f[F_GJ], k[VALVE_LAND], k, mu)
        yc = _lift(s[LC], 0.0, k)
        yr = _lift(s[LR], static_lift(d, k[K0_R], k[DISH_R], k[T_R], k[YMAX_R], k[FACE_R], k), k)
    valves = passage(d, k[PERIM_C] * yc, yc, k[VALVE_LAND], k, mu)
    valves += passage(d, k[PERIM_R] * yr, yr, k[VALVE_LAND], k, mu)
    q = bleed + valves
    if dp < 0.0:
        q = -q
    return q + k[LEAK_G] / mu * dp, yc, yr


# -- cavities ---------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def cavity_after(vc: float, p: float, k: FloatArray) -> float:
    """Cavity volume after one step at liquid pressure p: N bubbles (nuclei of volume V_n
    in all) whose walls move at Rayleigh's speed, Ṙ = ±√(2|p_v - p|/(3ρ)), so the volume
    changes at N 4πR² Ṙ = (36πN)^(1/3) (V + V_n)^(2/3) Ṙ; implicit in the radius."""
    if k[N_B] <= 0.0:
        return 0.0
    dv = k[P_V] - p
    if vc <= 0.0 and dv <= 0.0:
        return 0.0
    rate = dv / math.sqrt(1.5 * k[RHO] * (abs(dv) + P_RATE_REG))
    a = k[H] * k[C_NUC] * rate
    c = vc + k[V_N]
    # u³ - a u² - c = 0 in u = (V + V_n)^(1/3): one positive root whether the walls move
    # out (a > 0) or in; Newton from above it converges without overshoot
    u = max(a, 0.0) + c ** (1.0 / 3.0)
    for _ in range(50):
        g = u * u * u - a * u * u - c
        dg = 3.0 * u * u - 2.0 * a * u
        un = u - g / dg
        if un <= 0.0:
            un = 0.5 * u
        if abs(un - u) <= 1e-12 * u:
            u = un
            break
        u = un
    out = u * u * u - k[V_N]
    return out if out > 0.0 else 0.0


# -- the two balances -------------------------------------------------------------------
@njit(cache=True, nogil=True)
def gas_state(y: float, s: FloatArray, k: FloatArray, t_wall: float) -> tuple[float, float]:
    """(pressure, temperature K) of the gas with the floating piston at y after the
    step: adiabatic over the step, then relaxed towards the wall over TAU_G."""
    vg = k[VG0] - k[A_G] * y
    if vg < GAS_LIMIT * k[VG0]:
        vg = GAS_LIMIT * k[VG0]
    vg_old = k[VG0] - k[A_G] * s[YG]
    if vg_old < GAS_LIMIT * k[VG0]:
        vg_old = GAS_LIMIT * k[VG0]
    t_ad = s[TG] * (vg_old / vg) ** (k[GAMMA] - 1.0)
    t = t_wall + (t_ad - t_wall) * math.exp(-k[H] / k[TAU_G])
    return k[P0] * (k[VG0] / vg) * (t / k[T_FILL]), t


@njit(cache=True, nogil=True)
def _mass_flux(
    dp: float, p_r: float, p_k: float, s: FloatArray, k: FloatArray, f: FloatArray, mu: float
) -> tuple[float, float, float, float]:
    q, yc, yr = flow(dp, s, k, f, mu)
    up = p_k if q > 0.0 else p_r
    return q / specific_volume(k, up), q, yc, yr


@njit(cache=True, nogil=True)
def rebound_residual(
    p_r: float, p_k: float, x: float, s: FloatArray, k: FloatArray, f: FloatArray, mu: float
) -> float:
    """Contents less room in the rebound chamber after the step (m³), falling in p_r."""
    mdot, _, _, _ = _mass_flux(p_k - p_r, p_r, p_k, s, k, f, mu)
    m_r = s[MR] + k[H] * mdot
    room = k[A_A] * (k[L_COL] + x)
    gas = s[NG] * P_ATM / (p_r if p_r > P_AIR_MIN else P_AIR_MIN)
    return float(m_r * specific_volume(k, p_r) + cavity_after(s[VC], p_r, k) + gas - room)


@njit(cache=True, nogil=True)
def compression_residual(
    y: float,
    p_r: float,
    x: float,
    s: FloatArray,
    k: FloatArray,
    f: FloatArray,
    mu: float,
    t_wall: float,
) -> float:
    """Contents less room in the compression chamber after the step, falling in y."""
    p_k, _ = gas_state(y, s, k, t_wall)
    mdot, _, _, _ = _mass_flux(p_k - p_r, p_r, p_k, s, k, f, mu)
    m_k = s[MK] - k[H] * mdot
    room = k[A_P] * (k[L_COL] - x) + k[A_G] * y
    return float(m_k * specific_volume(k, p_k) - room)


@njit(cache=True, nogil=True)
def _residual(
    which: int,
    z: float,
    other: float,
    x: float,
    s: FloatArray,
    k: FloatArray,
    f: FloatArray,
    mu: float,
    t_wall: float,
) -> float:
    if which == 0:
        return rebound_residual(z, other, x, s, k, f, mu)
    return compression_residual(z, other, x, s, k, f, mu, t_wall)


@njit(cache=True, nogil=True)
def solve(
    which: int,
    z0: float,
    step: float,
    tol: float,
    other: float,
    x: float,
    s: FloatArray,
    k: FloatArray,
    f: FloatArray,
    mu: float,
    t_wall: float,
) -> float:
    """The root of a residual that falls strictly in z: bracket it from z0 by growing
    steps, then regula falsi with the Illinois halving."""
    f0 = _residual(which, z0, other, x, s, k, f, mu, t_wall)
    if f0 == 0.0:
        return z0
    lo, flo, hi, fhi = z0, f0, z0, f0
    d = step
    for _ in range(80):
        if f0 > 0.0:
            hi = z0 + d
            fhi = _residual(which, hi, other, x, s, k, f, mu, t_wall)
            if fhi <= 0.0:
                break
            lo, flo = hi, fhi
        else:
            lo = z0 - d
            flo = _residual(which, lo, other, x, s, k, f, mu, t_wall)
            if flo >= 0.0:
                break
            hi, fhi = lo, flo
        d *= 4.0
    # now flo > 0 >= fhi, lo < hi
    side = 0
    z = 0.5 * (lo + hi)
    for _ in range(200):
        if hi - lo <= tol:
            break
        z = (lo * fhi - hi * flo) / (fhi - flo)
        if not lo < z < hi:
            z = 0.5 * (lo + hi)
        fz = _residual(which, z, other, x, s, k, f, mu, t_wall)
        if fz > 0.0:
            lo, flo = z, fz
            if side == 1:
                fhi *= 0.5
            side = 1
        elif fz < 0.0:
            hi, fhi = z, fz
            if side == -1:
                flo *= 0.5
            side = -1
        else:
            return z
    return z


# -- seal and bump stop -----------------------------------------------------------------
@njit(cache=True, nogil=True)
def seal_level(v: float, k: FloatArray) -> float:
    """The seal's sliding force at speed v (Hess & Soom): F_c + F_b / (1 + (v/v_s)²)."""
    r = v / k[VS]
    return float(k[FC] + k[FB] / (1.0 + r * r))


@njit(cache=True, nogil=True)
def _alpha(u: float, u_ss: float, u_ba: float) -> float:
    """Dupont's elasto-plastic switch on the deflection u along the motion: 0 (elastic)
    up to the breakaway deflection, 1 (sliding) from the steady one, a half-sine between."""
    if u <= u_ba:
        return 0.0
    if u >= u_ss:
        return 1.0
    return 0.5 * math.sin(math.pi * (u - 0.5 * (u_ss + u_ba)) / (u_ss - u_ba)) + 0.5


@njit(cache=True, nogil=True)
def seal_step(z: float, dx: float, v: float, k: FloatArray) -> float:
    """The seal's deflection after the rod travels dx (implicit in the travel):
    dz/dx = 1 - α(z) z / z_ss(v), z_ss = level(v)/σ0 (Dupont et al. 2002)."""
    if dx == 0.0:
        return z
    sgn = 1.0 if dx > 0.0 else -1.0
    d = abs(dx)
    u = sgn * z
    u_ss = seal_level(v, k) / k[SIG0]
    u_ba = k[ZBA] * u_ss
    lo = u if u < u_ss else u_ss
    hi = u + d
    w = 0.5 * (lo + hi)
    for _ in range(80):
        g = w - u - d * (1.0 - _alpha(w, u_ss, u_ba) * w / u_ss)
        if g > 0.0:
            hi = w
        else:
            lo = w
        if hi - lo < 1e-14:
            break
        w = 0.5 * (lo + hi)
    return sgn * w


@njit(cache=True, nogil=True)
def bump_force(x: float, fm: float, k: FloatArray) -> tuple[float, float]:
    """(force, Maxwell branch's force) of the bump rubber at x given the branch's force
    after the step: an exponential backbone F_10 (e^(δ/ℓ) - 1)/(e^(10 mm/ℓ) - 1) and a
    Maxwell branch in parallel; it pushes, never pulls."""
    d = x - k[XB]
    if d <= 0.0 or k[F10] <= 0.0:
        return 0.0, 0.0
    fe = k[F10] * math.expm1(d / k[LB]) / math.expm1(0.010 / k[LB])
    tot = fe + fm
    return (tot if tot > 0.0 else 0.0), fm


@njit(cache=True, nogil=True)
def _biquad(x: float, s: FloatArray, i1: int, i2: int, k: FloatArray, c: int) -> float:
    y = k[c] * x + s[i1]
    s[i1] = k[c + 1] * x - k[c + 3] * y + s[i2]
    s[i2] = k[c + 2] * x - k[c + 4] * y
    return float(y)


# -- one step and a chunk ---------------------------------------------------------------
@njit(cache=True, nogil=True)
def step(
    s: FloatArray, k: FloatArray, f: FloatArray, x: float, v: float, a: float
) -> tuple[float, float]:
    """Advance the state by one sub-step to rod position x (speed v, acceleration a):
    returns (true force, hydraulic power)."""
    mu = viscosity(k, s[TO])
    t_wall = k[T_FILL] + k[COUPLING] * (s[TB] + KELVIN - k[T_FILL])
    p_r, y = s[PR], s[YG]
    p_k, _ = gas_state(y, s, k, t_wall)
    for _ in range(40):
        p_r_new = solve(0, p_r, 1.0e3, 1e-3 + 1e-10 * abs(p_r), p_k, x, s, k, f, mu, t_wall)
        y_new = solve(1, y, 1.0e-6, 1e-13, p_r_new, x, s, k, f, mu, t_wall)
        p_k, _ = gas_state(y_new, s, k, t_wall)
        done = abs(p_r_new - p_r) < 0.01 and abs(y_new - y) < 1e-11
        p_r, y = p_r_new, y_new
        if done:
            break
    p_k, t_g = gas_state(y, s, k, t_wall)
    dp = p_k - p_r
    mdot, q, yc, yr = _mass_flux(dp, p_r, p_k, s, k, f, mu)
    h = k[H]
    vc = cavity_after(s[VC], p_r, k)
    # released air: out of solution into the cavities' walls, back into solution when it
    # is squeezed (faster the higher the pressure)
    area = k[C_NUC] * (vc + k[V_N]) ** (2.0 / 3.0) if vc > 0.0 else 0.0
    back = h * max(p_r, 0.0) / (k[P0] * k[TAU_RES])
    s[NG] = (s[NG] + h * k[U_DES] * area) / (1.0 + back)
    s[MR] += h * mdot
    s[MK] -= h * mdot
    s[PR] = p_r
    s[PK] = p_k
    s[YG] = y
    s[TG] = t_g
    s[VC] = vc
    s[LC] = yc
    s[LR] = yr
    # seal: elasto-plastic deflection, lip drag growing as (μ v)^0.4
    z = seal_step(s[Z], x - s[X], v, k)
    s[Z] = z
    f_seal = k[SIG0] * z
    if k[LIP] > 0.0 and v != 0.0:
        lip = k[LIP] * (mu * abs(v) / (k[MU40] * 0.1)) ** 0.4
        f_seal += lip if v > 0.0 else -lip
    # bump stop: the Maxwell branch follows the rubber's compression (backward Euler)
    d_new, d_old = x - k[XB], s[X] - k[XB]
    if d_new > 0.0 and k[F10] > 0.0:
        into = d_new - (d_old if d_old > 0.0 else 0.0)
        s[FM] = (s[FM] + k[KM] * into) / (1.0 + h / k[TAU_M])
    else:
        s[FM] = 0.0
    f_bump, _ = bump_force(x, s[FM], k)
    force = p_k * k[A_P] - p_r * k[A_A] - P_ATM * k[A_ROD] + f_seal + f_bump + k[M_ROD] * a
    # heat: the oil takes what the piston dissipates, the body what the seal does
    p_hyd = abs(dp * q) * k[HEAT]
    p_seal = abs(f_seal * v)
    flow_ob = k[G_OB] * (s[TO] - s[TB])
    dt_amb = s[TB] - f[F_AMB]
    conv = k[H_CONV] * (abs(dt_amb) ** 1.25) * (1.0 if dt_amb > 0.0 else -1.0)
    s[TO] += h * (p_hyd - flow_ob) / k[C_O]
    s[TB] += h * (p_seal + flow_ob - conv) / k[C_B]
    s[X] = x
    s[V] = v
    s[FORCE] = force
    return force, p_hyd


@njit(cache=True, nogil=True)
def advance(
    s: FloatArray,
    k: FloatArray,
    f: FloatArray,
    ring: FloatArray,
    xs: FloatArray,
    vs: FloatArray,
    acc: FloatArray,
    m: int,
    out: FloatArray,
) -> None:
    """Run len(xs) sub-steps (m a sample); out[:, i] for sample i: true force, sensed
    force, sensed position, body temperature, oil temperature, rebound pressure, cavity
    volume, released gas (m³ at 1 atm), the seal's elastic force (its lip drag apart)."""
    n = xs.size // m
    nr = ring.size
    for i in range(n):
        force = 0.0
        xf = 0.0
        for j in range(m):
            jj = i * m + j
            force, _ = step(s, k, f, xs[jj], vs[jj], acc[jj])
            # load cell, then the anti-alias Bessel; the position through the same Bessel
            fl = _biquad(force, s, LC_Z1, LC_Z2, k, LC_B0)
            fl = _biquad(fl, s, FAA0_Z1, FAA0_Z2, k, AA0_B0)
            fl = _biquad(fl, s, FAA1_Z1, FAA1_Z2, k, AA1_B0)
            xf = _biquad(xs[jj], s, XAA0_Z1, XAA0_Z2, k, AA0_B0)
            xf = _biquad(xf, s, XAA1_Z1, XAA1_Z2, k, AA1_B0)
            at = int(s[RING_AT])
            ring[at] = fl
            s[RING_AT] = (at + 1) % nr
        # the force channel is read SKEW sub-steps late (linear between sub-samples)
        newest = (int(s[RING_AT]) - 1) % nr
        back = k[SKEW]
        whole = math.floor(back)
        frac = back - whole
        f0 = ring[(newest - whole) % nr]
        f1 = ring[(newest - whole - 1) % nr]
        out[0, i] = force
        out[1, i] = f0 + frac * (f1 - f0)
        out[2, i] = xf
        out[3, i] = s[TB]
        out[4, i] = s[TO]
        out[5, i] = s[PR]
        out[6, i] = s[VC]
        out[7, i] = s[NG]
        out[8, i] = k[SIG0] * s[Z]
