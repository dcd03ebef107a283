"""One implicit step of the rebound chamber (model/chamber.py integrates them): the
chamber's balance over the step and the safeguarded Newton iteration that finds its root.

The balance (`_balance`) is the volume a step ending at chamber pressure p leaves
unaccounted for: the flow demand less the flow law's q(p_c - p) (`_signed_flow`: bleed
orifice with its laminar land, shim stack, leak), less what the contents (`_occupied`: oil
and a fixed amount of isothermal air) and the vapour (`_vapour_at`) took, with p_c raised
by what they took from the gas column (`_gas`). It rises strictly with p, so the step's
end is its one root (`_step`); at the release pressure the vapour is the unknown instead
(`_at_floor`). Compiled with numba; the kernels take the chamber's constants as one
record (`CONSTANTS`) and the step's inputs as one `Step`.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple, Protocol, cast

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

MIN_PRESSURE_PA = 1.0  # absolute: air cannot be compressed to nothing nor stretched past it
MAX_NEWTON = 100
EPS = 2.220446049250313e-16  # machine epsilon of a double (numpy.finfo(float).eps)
CONTENTS_ULPS = 16.0  # the balance's rounding, in ulps of the contents it subtracts
GAS_CAP = 0.9  # the contents may take at most this share of the gas column (beyond any damper)

# The chamber's constants (what a whole integration holds fixed) are one record of the
# `CONSTANTS` dtype (a NumPy structured scalar, typed by numba as a record and passed by
# reference; `Constants` is what the type checker sees of it), not a dozen scalars each
# kernel takes. A jitclass would do as well in the loop, but numba cannot cache a
# function that takes one, and every process would compile the chamber anew. `Step` is
# what one implicit step adds (its inputs, interpolated between samples), a named tuple
# of floats built in the loop. The parts `_step` is split into are inlined into it
# (inline="always", in numba's own IR): compiled apart, each layer's LLVM module is
# optimised again with all it calls.
CONSTANTS = np.dtype(
    [
        ("valves", np.float64, (2, 5)),  # compression, rebound: chamber._valve_row
        ("c", np.float64),  # C_d √(2/ρ)
        ("a_q", np.float64),  # the annulus less the Couette drag area
        ("a_r", np.float64),  # the rebound chamber's area: V(x) = A_r (L + x)
        ("length", np.float64),  # L
        ("air0", np.float64),  # the air's volume at p₀
        ("p0", np.float64),  # the charge, absolute
        ("c_oil", np.float64),
        ("floor", np.float64),  # the release pressure (-1e300 when there is none)
        ("has_floor", np.bool_),
        ("r_form", np.float64),  # R_e, R_c: `_vapour_at`
        ("r_cond", np.float64),
        ("gas_n", np.float64),  # the gas column's polytropic index
    ],
    align=True,
)


class Constants(Protocol):
    """A `CONSTANTS` record's fields as the kernels read them (what the type checker sees
    of the NumPy structured scalar)."""

    valves: FloatArray
    c: float
    a_q: float
    a_r: float
    length: float
    air0: float
    p0: float
    c_oil: float
    floor: float
    has_floor: bool
    r_form: float
    r_cond: float
    gas_n: float


def constants(**fields: Any) -> Constants:
    """A `CONSTANTS` record with these fields (the others zero): a NumPy record, whose
    fields Python reads by name as the kernels do (numba types it as the structured
    scalar it is)."""
    rec = np.zeros((), dtype=CONSTANTS)
    for name, value in fields.items():
        rec[name] = value
    return cast("Constants", rec.view(np.recarray)[()])


class Step(NamedTuple):
    """One implicit step's inputs beyond the chamber's constants."""

    occ_old: float  # the contents it starts from (`_step`)
    vap_old: float  # the vapour it starts with
    base: float  # p_c of the algebraic solve
    q_demand: float  # A_q ẋ, m³/s
    dt: float
    vol: float  # the chamber's volume
    a_bc: float
    a_bt: float
    k_leak: float
    lam: float  # the bleed's laminar land
    sc: float  # the Δp scale of a term (1: none)
    gas_volume: float  # the gas column's volume (0: p_c as given)


@njit(cache=True)
def _flow(
    d: float, a_b: float, valve: FloatArray, c: float, k_leak: float, lam: float
) -> tuple[float, float]:
    """q(d) and dq/dd for d >= 0 through one direction's bleed (with its laminar land λ,
    model/flow.py), shim stack and leak."""
    perim, face, preload, stiff, lift_max = valve[0], valve[1], valve[2], valve[3], valve[4]
    lift = (d * face - preload) / stiff
    bleed = 0.0 if lam > 0.0 else a_b  # a laminar bleed is added apart below
    if lift <= 0.0:
        area, darea = bleed, 0.0
    elif lift >= lift_max:
        area, darea = bleed + perim * lift_max, 0.0
    else:
        area, darea = bleed + perim * lift, perim * face / stiff
    s = math.sqrt(d)
    q = c * area * s + k_leak * d
    slope = c * darea * s + k_leak
    if s > 0.0:
        slope += 0.5 * c * area / s
    elif area > 0.0:
        slope = 1.0e300  # √d: infinitely steep at zero
    if lam > 0.0 and a_b > 0.0:
        # q_b = 2A²d/(λ + D), D = √(λ² + 4A²d/c²): linear (A²/λ) at zero, orifice-like fast.
        a2 = a_b * a_b
        dd = math.sqrt(lam * lam + 4.0 * a2 * d / (c * c))
        q += 2.0 * a2 * d / (lam + dd)
        slope += (2.0 * a2 * (lam + dd) - 2.0 * a2 * d * (2.0 * a2 / (c * c * dd))) / (
            (lam + dd) ** 2
        )
    return q, slope


@njit(cache=True)
def _signed_flow(d: float, s: Step, k: Constants) -> tuple[float, float]:
    """q and dq/dd through the piston at drop d, the flow law taken at d / sc: a term
    that scales the algebraic solve's Δp by sc (the oil's temperature) scales the drop
    each flow needs by the same."""
    sc = s.sc
    if sc == 1.0:  # as a rule: no term scaled the solve
        if d >= 0.0:
            return _flow(d, s.a_bc, k.valves[0], k.c, s.k_leak, s.lam)
        q, slope = _flow(-d, s.a_bt, k.valves[1], k.c, s.k_leak, s.lam)
        return -q, slope
    e = d / sc
    if e >= 0.0:
        q, slope = _flow(e, s.a_bc, k.valves[0], k.c, s.k_leak, s.lam)
        return q, slope / sc
    q, slope = _flow(-e, s.a_bt, k.valves[1], k.c, s.k_leak, s.lam)
    return -q, slope / sc


@njit(cache=True)
def _occupied(p: float, vol: float, k: Constants) -> tuple[float, float]:
    """Volume the chamber's oil and air take up at pressure p (up to a constant), and its
    derivative (negative: compliance). The air is a fixed amount, air0 of volume at p0
    (isothermal), so its part is an exact differential: a cycle returns every bubble to
    its size and pumps no oil (an air volume scaled with the chamber's, V(x) α p₀/p²,
    does not: around a loop in x and p it moves oil through the piston every cycle)."""
    air0 = k.air0
    pe = max(p, MIN_PRESSURE_PA)
    oil = max(vol - air0, 0.0)
    occ = air0 * k.p0 / pe - oil * k.c_oil * p
    docc = -(air0 * k.p0 / (pe * pe) + oil * k.c_oil)
    return occ, docc


@njit(cache=True)
def _gas(
    occ_now: float, docc: float, vapour: float, s: Step, k: Constants
) -> tuple[float, float, float]:
    """(p_c, dp_c/dp, dp_c/dV_vap) with the contents at occ_now (their slope docc): the
    chamber's contents beyond the rigid oil's volume (air expanded below the charge,
    vapour) are oil the rebound chamber did not take, so the gas column is that much
    shorter and p_c = base (V_g / (V_g - ΔV))^n. No gas column given: p_c = base."""
    base, gas_volume, n = s.base, s.gas_volume, k.gas_n
    if gas_volume <= 0.0:
        return base, 0.0, 0.0
    occ_ref, _ = _occupied(k.p0, s.vol, k)
    grow = occ_now - occ_ref + vapour
    cap = GAS_CAP * gas_volume
    if grow >= cap:  # beyond any damper: held, so the balance stays monotone
        return base * (gas_volume / (gas_volume - cap)) ** n, 0.0, 0.0
    ratio = gas_volume / (gas_volume - grow)
    pc = base * (ratio if n == 1.0 else ratio**n)  # isothermal: no power to take
    per_volume = n * pc / (gas_volume - grow)
    return pc, per_volume * docc, per_volume


@njit(cache=True)
def _vapour_at(p: float, vap_old: float, dt: float, k: Constants) -> tuple[float, float]:
    """(vapour at the step's end, its derivative in p) when the chamber ends the step at
    p, off its floor. Below it vapour forms at (p_v - p)/R_e (R_e > 0 there: with none the
    chamber never sits below), above it condenses at (p - p_v)/R_c while there is any
    (R_c = 0: at once)."""
    floor, r_cond = k.floor, k.r_cond
    if p < floor:
        return vap_old + dt * (floor - p) / k.r_form, -dt / k.r_form
    if r_cond <= 0.0:
        return 0.0, 0.0
    g = vap_old - dt * (p - floor) / r_cond
    if g <= 0.0:
        return 0.0, 0.0
    return g, -dt / r_cond


@njit(cache=True)
def _balance(p: float, s: Step, k: Constants) -> tuple[float, float, float, float, float]:
    """(F, dF/dp, p_c, vapour, dp_c/dp) of a step ending at chamber pressure p (off the floor):
    F = V_vap,old + dt (Q - q(p_c - p)) - occ(p) + occ(p_old) - V_vap(p), the volume the
    step leaves unaccounted for. It rises strictly with p: q falls as p rises and p_c
    falls, the contents shrink, and less vapour forms or more condenses."""
    g, dg = 0.0, 0.0
    if k.has_floor:
        g, dg = _vapour_at(p, s.vap_old, s.dt, k)
    occ, docc = _occupied(p, s.vol, k)
    pc, dpc_dp, dpc_dv = _gas(occ, docc, g, s, k)
    q, dq = _signed_flow(pc - p, s, k)
    f = s.vap_old + s.dt * (s.q_demand - q) - occ + s.occ_old - g
    dpc = dpc_dp + dpc_dv * dg
    df = -s.dt * dq * (dpc - 1.0) - docc - dg
    return f, df, pc, g, dpc


class Reach(NamedTuple):
    """Where each bound of a step's bracket is looked for while it is open: `_bound`
    doubles `width` from `lo_from` down (from `hi_from` up), and the bound it finds lies
    beyond `lo_at` (`hi_at`), the first doubling's reach."""

    lo_from: float
    lo_at: float
    hi_from: float
    hi_at: float
    width: float


@njit(cache=True)
def _bound(start: float, direction: float, width: float, s: Step, k: Constants) -> float:
    """From `start` in `direction` (+1 up, -1 down) by doubling steps until the balance
    has that sign: an upper bound (F > 0) or a lower one (F < 0)."""
    at = start + direction * width
    for _ in range(200):
        f = _balance(at, s, k)[0]
        if direction * f > 0.0:
            break
        width *= 2.0
        at += direction * width
    return at


@njit(cache=True)
def _pinned(
    lo: float, lo_open: bool, hi: float, hi_open: bool, r: Reach, s: Step, k: Constants
) -> tuple[float, float]:
    """The bracket with each bound still open found by its doubling."""
    if lo_open:
        lo = _bound(r.lo_from, -1.0, r.width, s, k)
    if hi_open:
        hi = _bound(r.hi_from, 1.0, r.width, s, k)
    return lo, hi


@njit(cache=True)
def _floor_balance(vv: float, rest: float, s: Step, k: Constants) -> tuple[float, float, float]:
    """(G, dG/dV, p_c) of a step ending at the floor with vapour V:
    G(V) = V - rest - dt (Q - q(p_c(floor, V) - floor)), the volume left unaccounted for.
    It rises in V: more vapour shortens the gas column, p_c rises and so does the outflow."""
    floor = k.floor
    occ, docc = _occupied(floor, s.vol, k)
    pc, _, dpc_dv = _gas(occ, docc, vv, s, k)
    q, dq = _signed_flow(pc - floor, s, k)
    return vv - rest - s.dt * (s.q_demand - q), 1.0 + s.dt * dq * dpc_dv, pc


@njit(cache=True, inline="always")
def _tolerance(s: Step) -> float:
    """Settled within 1e-12 of the step's flow, or within what the arithmetic resolves: the
    balance subtracts the chamber's contents (occ, of the order of the air's volume),
    which it cannot know better than a few ulps of them. At reversal (no flow) the first
    bound alone was below that rounding, so no iterate could meet it."""
    tol = 1.0e-12 * (abs(s.q_demand) * s.dt + 1.0e-12) + 1.0e-22
    tol += CONTENTS_ULPS * EPS * (abs(s.occ_old) + abs(s.vap_old) + abs(s.q_demand) * s.dt)
    return tol


@njit(cache=True)
def _step(p_guess: float, s: Step, k: Constants) -> tuple[float, float, float]:
    """One implicit step: (chamber pressure p, vapour volume, p_c) at its end.

    `s.occ_old`: the contents the step starts from, occ(p_old) for backward Euler over dt;
    occ(p_old) + (occ(p_old) - occ(p_older))/3 with dt two thirds of the step for BDF2
    (the history enters the balance only as this constant, so both are one solve).

    Solved in p, with p_c(p, V_vap) the gas the contents compress (`_gas`) and V_vap(p)
    the vapour the step's rates leave (`_vapour_at`), so the chamber, its vapour and the
    gas are one implicit step whose balance (`_balance`) rises strictly with p. At the
    floor itself the vapour is whatever closes the balance within what the rates allow
    (`_at_floor`). Its root is the step's end unless the balance needs more vapour than
    that (the chamber falls below the floor, R_e > 0) or less (it rises above,
    condensing what is left at R_c).
    """
    # The parts are called from here, not from each other: numba copies an inlined
    # part's code into each caller, so a chain of them copies the innermost over and over.
    tol = _tolerance(s)
    lo, hi = -math.inf, math.inf
    if k.has_floor:
        where, lo, hi, rest, pc = _at_floor(s, k)
        if where == AT_FLOOR_AS_BEFORE:
            return k.floor, s.vap_old, pc
        if where == AT_FLOOR:
            vv, pc = _floor_vapour(rest, tol, s, k)
            return k.floor, vv, pc
    if not math.isfinite(lo) and not math.isfinite(hi) and k.air0 > 0.0:
        lo = MIN_PRESSURE_PA  # the air takes any volume as p falls to nothing: F < 0
    p, lo, lo_open, hi, hi_open, r = _bracket(p_guess, lo, hi, s, k)
    return _iterate(p, lo, lo_open, hi, hi_open, r, tol, s, k)


OFF_FLOOR, AT_FLOOR_AS_BEFORE, AT_FLOOR = 0, 1, 2  # where a step ends (`_at_floor`)


@njit(cache=True, inline="always")
def _at_floor(s: Step, k: Constants) -> tuple[int, float, float, float, float]:
    """(where the step ends, the bracket on p off the floor, `rest` of `_floor_balance`,
    p_c). The vapour at the floor is any amount with instant rates (R_e = R_c = 0, a hard
    floor), no less than before with a finite condensation, no more with a finite
    formation: G(V) rises in V (`_floor_balance`); its root in [v_min, v_max] is the
    vapour at the floor (AT_FLOOR: `_floor_vapour`; AT_FLOOR_AS_BEFORE: v_min = v_max, the
    old vapour), unless G has one sign there (OFF_FLOOR)."""
    lo, hi = -math.inf, math.inf
    vap_old = s.vap_old
    v_min = vap_old if k.r_cond > 0.0 else 0.0
    v_max = vap_old if k.r_form > 0.0 else math.inf
    occ_f, _ = _occupied(k.floor, s.vol, k)
    rest = vap_old - occ_f + s.occ_old
    g_min, _, pc = _floor_balance(v_min, rest, s, k)
    g_max = -1.0
    if g_min <= 0.0 and math.isfinite(v_max):
        g_max, _, pc = _floor_balance(v_max, rest, s, k)
    if g_min > 0.0:
        lo = k.floor  # the balance needs less vapour than the rates leave: above
    elif math.isfinite(v_max) and g_max < 0.0:
        hi = k.floor  # more than they can form: the chamber falls below its floor
    elif math.isfinite(v_max):
        return AT_FLOOR_AS_BEFORE, lo, hi, rest, pc  # v_min = v_max = the old vapour
    else:
        return AT_FLOOR, lo, hi, rest, pc
    return OFF_FLOOR, lo, hi, rest, pc


@njit(cache=True, inline="always")
def _floor_vapour(rest: float, tol: float, s: Step, k: Constants) -> tuple[float, float]:
    """(vapour, p_c) at the floor with no upper limit on the vapour: G's root above v_min
    (`_at_floor`'s) by a safeguarded Newton iteration, from an upper bound found by
    doubling."""
    v_min = s.vap_old if k.r_cond > 0.0 else 0.0
    v_lo, v_hi = v_min, max(v_min, rest + s.dt * abs(s.q_demand), 1.0e-15)
    for _ in range(200):
        if _floor_balance(v_hi, rest, s, k)[0] >= 0.0:
            break
        v_hi *= 2.0
    vv = min(max(s.vap_old, v_lo), v_hi)
    settled = False
    moved = math.inf  # the last step's length (the safeguard below)
    for _ in range(MAX_NEWTON):
        f, df, pc = _floor_balance(vv, rest, s, k)
        if abs(f) <= tol:
            settled = True
            break
        if f > 0.0:
            v_hi = vv
        else:
            v_lo = vv
        step = vv - f / df
        if not (v_lo < step < v_hi) or not math.isfinite(step) or abs(step - vv) > 0.5 * moved:
            step = 0.5 * (v_lo + v_hi)
        moved = abs(step - vv)
        vv = step
        if v_hi - v_lo <= 1.0e-12 * (vv + 1.0e-15):
            break
    if not settled:
        _, _, pc = _floor_balance(vv, rest, s, k)
    return vv, pc


@njit(cache=True, inline="always")
def _bracket(
    p_guess: float, lo: float, hi: float, s: Step, k: Constants
) -> tuple[float, float, bool, float, bool, Reach]:
    """Where `_iterate` starts from p_guess to find the balance's root within [lo, hi]
    (either may be infinite: no bound yet): (p, lo, lo still open, hi, hi still open, the
    open bounds' reach).

    A lower bound (F < 0) where there is none yet, and an upper one (F > 0), by doubling
    from p_guess. Each is found only when the iteration needs it: Newton's steps from
    p_guess rarely leave the first doubling's reach (lo_at < p < hi_at), and within it
    every decision below is the same whatever the bound, so the result is the one the
    bounds found first would give, for two evaluations fewer a step. The old order
    pinned both first; the lazy one is compared with it bit for bit
    (tests/model/test_chamber_brackets.py)."""
    width = max(abs(p_guess) * 0.1, 1.0e3)
    lo_open = not math.isfinite(lo)  # lo is the doubling's, not evaluated yet
    lo_from = min(p_guess, hi)
    hi_open = not math.isfinite(hi)
    # Had lo been pinned first it would sit below p_guess, so the upper doubling starts
    # at p_guess either way.
    hi_from = p_guess if lo_open else max(p_guess, lo)
    r = Reach(lo_from, lo_from - width, hi_from, hi_from + width, width)
    p = p_guess if lo_open else max(p_guess, lo)
    if not hi_open:
        p = min(p, hi)
    if (not lo_open and not lo < p) or (not hi_open and not p < hi):
        lo, hi = _pinned(lo, lo_open, hi, hi_open, r, s, k)
        lo_open = hi_open = False
        p = 0.5 * (lo + hi)
    return p, lo, lo_open, hi, hi_open, r


@njit(cache=True, inline="always")
def _iterate(
    p: float,
    lo: float,
    lo_open: bool,
    hi: float,
    hi_open: bool,
    r: Reach,
    tol: float,
    s: Step,
    k: Constants,
) -> tuple[float, float, float]:
    """The balance's root from p within its bracket (`_bracket`; a bound still open: `r`),
    by a safeguarded Newton iteration: (p, vapour, p_c)."""
    vv, pc = 0.0, s.base
    settled = False
    moved = math.inf  # the last step's length (the safeguard below)
    newton = math.inf  # the last step's length if it was Newton's, else inf
    for _ in range(MAX_NEWTON):
        f, df, pc, vv, dpc = _balance(p, s, k)
        if abs(f) <= tol:
            settled = True
            break
        if f > 0.0:
            hi, hi_open = p, False
        else:
            lo, lo_open = p, False
        step = p - f / df if df > 0.0 else math.nan
        # Newton's step must at least halve the last one (else bisect: a safeguarded
        # Newton iteration, as Numerical Recipes' rtsafe). At reversal the flow law turns
        # from one valve's √Δp to the other's, and Newton's steps there could cycle
        # between the two sides of the root, each landing just inside the bracket: 100
        # iterations later the step ended 350 Pa off its root on one side or the other,
        # by the parity of the count, which the ninth digit of the air fraction decided.
        inside = math.isfinite(step) and abs(step - p) <= 0.5 * moved
        if inside:
            if lo_open and not step > r.lo_at:
                lo, lo_open = _bound(r.lo_from, -1.0, r.width, s, k), False
            if hi_open and not step < r.hi_at:
                hi, hi_open = _bound(r.hi_from, 1.0, r.width, s, k), False
            inside = (lo_open or lo < step) and (hi_open or step < hi)
        if not inside:
            lo, hi = _pinned(lo, lo_open, hi, hi_open, r, s, k)
            lo_open = hi_open = False
            step = 0.5 * (lo + hi)
        elif newton < math.inf and abs(step - p) ** 2 * df <= tol * newton:
            # Newton's step after Newton's step: this one's error is at most its length
            # times the rate the last two show (|δ|²/|δ_last|: a quadratic convergence's
            # is far less), and that leaves the balance within tolerance. Its end is
            # taken without the balance that would only confirm it (2.1 balances a step
            # where that took 3.1); p_c to first order in the step (its error is the
            # step's square), the vapour at the end exactly.
            pc += dpc * (step - p)
            if k.has_floor:
                vv = _vapour_at(step, s.vap_old, s.dt, k)[0]
            return step, vv, pc
        newton = abs(step - p) if inside else math.inf
        moved = abs(step - p)
        p = step
        # The bracket is at least this wide while a bound is still open.
        gap = (r.hi_at if hi_open else hi) - (r.lo_at if lo_open else lo)
        if gap <= 1.0e-12 * (abs(p) + 1.0):
            lo, hi = _pinned(lo, lo_open, hi, hi_open, r, s, k)
            lo_open = hi_open = False
            if hi - lo <= 1.0e-12 * (abs(p) + 1.0):
                break
    if not settled:  # else pc and vv are the settled pressure's already
        _, _, pc, vv, _ = _balance(p, s, k)
    return p, vv, pc
