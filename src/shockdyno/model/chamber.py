"""The rebound chamber as a state: its pressure and its vapour volume, integrated in time.

The paper's model is algebraic: Δp is the drop that passes the flow demand, q(Δp) = A_q ẋ
(A_q the annulus less the Couette drag area). Where the oil is not rigid, or the chamber
empties below its vapour pressure, Δp has a history. The chamber's volume balance is

    A_q ẋ dt = q(Δp) dt + d[occ(p)] + d[V_vap],     Δp = p_c - p,

where the chamber's oil and air occupy occ(p) = a₀ p₀ / p - (V(x) - a₀) c_oil p: a fixed
amount of free air, a₀ = α V₀ of volume at the charge pressure p₀ (α its fraction of the
chamber's mid-stroke volume V₀ = A_r L), isothermal (so 1/β_eff = (1-α) c_oil + α p₀/p²
at mid-stroke, Wood's law at the local pressure: the air softens the oil most where the
pressure is lowest), and oil of compressibility c_oil, which may include what gives
with it (a tube's swell, seals): an effective compliance. V(x) = A_r (L + x) is the
chamber's volume, L the spec's oil column. The air's part is an exact differential, so
a cycle pumps no oil through the piston (a V(x)-scaled air volume would). q is the
model's own flow law (bleed orifice with its laminar land, shim stack, leak), the same
as the algebraic solve's. At the release pressure p_v the chamber stops falling:
there vapour (and released air) fills the volume the flow does not,
and must be pushed back into solution before the pressure can build again (the lost
force after reversal of a cavitating damper). Neither need be instant: vapour forms at
(p_v - p)/R_e below the floor and condenses at (p - p_v)/R_c above it while any is left,
so a fast stroke pulls the chamber under p_v and a condensing one holds it over;
R_e = R_c = 0 is the hard floor.

Released gas: an oil that holds dissolved air gives some of it up while the chamber sits
at its floor, and that gas does not go back with the vapour. While the chamber holds
vapour, gas comes out at a fixed rate ṅ (its volume at one atmosphere per second), so
G = ṅ t over a void held t; above the floor it goes back into solution at
dG/dt = -G (p - p_v)/(P_atm τ) (Henry's law: driven by how far the pressure stands over
the one it was released at, in proportion to the gas there to dissolve). It takes
G P_atm / p (isothermal, Boyle), beside the air in occ(p), so after the void collapses
the chamber keeps a compliance the next strokes must compress: the rebound force lags
after the top reversal. G is advanced explicitly at each step's start (its rates are
seconds, the step a millisecond), and the step's balance sees what it released as new
volume. A periodic segment's passes move G to the fixed point of the cycle map the last
two passes show (Aitken), since it settles over seconds where the chamber's pressure
settles in a fraction of a cycle.

Each step is implicit and at most 1 ms long (sub-steps between samples further apart,
the motion interpolated linearly), so a fit's 5 ms samples see the state a 1 kHz
recording does: the balance is monotone in Δp, so a safeguarded Newton iteration finds
its one root. The steps are second order (BDF2 on the chamber's contents) wherever the
two steps before held no vapour, and backward Euler elsewhere (a segment's first step,
and while vapour forms or condenses, whose volume must stay ≥ 0). Backward Euler alone
lags the chamber by about half a step where it turns: at 2 % air and a 1.5 Hz stroke on
a nearly closed bleed it put the force up to 39 N (5.2 N RMS) off a 0.025 ms
integration just after reversal, where seal friction acts, and its error halved with
the step (first order); BDF2 is second order and the same cost per step. The loop is
compiled (numba), so a sweep's hundreds of thousands of samples take milliseconds. With
α = c_oil = 0 and no floor the step is exactly the algebraic solve: the paper's model.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import NamedTuple, Protocol, cast

import numpy as np
from numba import njit
from numpy.typing import NDArray

from shockdyno.model.composite import ATMOSPHERE_PA  # released gas: its volume at 1 atm
from shockdyno.model.flow import laminar_orifice, valve_land_flow
from shockdyno.model.recent import Recent
from shockdyno.model.shims import ShimStack
from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

MIN_PRESSURE_PA = 1.0  # absolute: air cannot be compressed to nothing nor stretched past it
MAX_NEWTON = 100
EPS = 2.220446049250313e-16  # machine epsilon of a double (numpy.finfo(float).eps)
CONTENTS_ULPS = 16.0  # the balance's rounding, in ulps of the contents it subtracts
GAS_CAP = 0.9  # the contents may take at most this share of the gas column (beyond any damper)
# A guided step (`linearised`) is one Newton step where the flow law is smooth over this
# many times the step: the step's error, its square times the law's curvature (√Δp's:
# 1/(4Δp)), is then at most 1/400000 of it. 1000 left column errors of 1e-3 of the
# column near the onset of vapour, where the flow turns through the piston and the
# chamber amplifies what a step leaves; 1e5 leaves 1e-6, below the solved columns' own.
GUIDE_REACH = 1.0e5
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
    # Vapour forms below the floor at (p_v - p)/R_e and condenses above it at (p - p_v)/R_c
    # (Pa·s/m³); 0: at once (a hard floor).
    form_resistance_pa_s_m3: float = 0.0
    condense_resistance_pa_s_m3: float = 0.0
    # Gas that comes out of solution while the chamber holds vapour, at this rate (m³/s of
    # gas at one atmosphere), and goes back into it above the floor at G (p - p_v)/(P_atm τ)
    # (`redissolve_s` τ: a gas 1 atm over the floor redissolves by 1/e in τ). 0: none.
    gas_release_m3_s: float = 0.0
    redissolve_s: float = math.inf

    @property
    def rigid(self) -> bool:
        """Whether the chamber holds no air and its oil does not compress: no compliance to
        integrate."""
        return self.air_fraction == 0.0 and self.oil_compressibility_per_pa == 0.0

    @property
    def inert(self) -> bool:
        """The paper's algebraic model: nothing to integrate."""
        return self.rigid and self.release_pa == -math.inf


def _valve_row(v: ShimStack) -> list[float]:
    return [v.perimeter_m, v.face_area_m2, v.preload_n, v.stiffness_n_per_m, v.max_lift_m]


def _per_sample(a: FloatArray, n: int) -> FloatArray:
    """`a` as the kernels take it: n contiguous, writable doubles (a read-only array would
    be another type to numba, and another compilation)."""
    out = np.ascontiguousarray(a, dtype=float)
    if out.shape != (n,):
        return np.array(np.broadcast_to(out, (n,)))
    return out if out.flags.writeable else out.copy()


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
    bleed_laminar: FloatArray | None = None,
    gas_volume: FloatArray | None = None,
    gas_index: float = 1.0,
    dp_scale: FloatArray | None = None,
    valve_laminar: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """(Δp, vapour volume m³, compression-chamber pressure, final state, released gas m³ at
    the chamber's pressure) for every sample, segment by segment.

    A segment starts in the static state (Δp = dp_static, no vapour) unless `carry`
    (single segment: the previous call's final state) is given, or `periodic` (whole
    cycles in their steady state: the state it ends in, found by repeating it).
    `gas_volume`: the gas column's volume per sample (m³) at the algebraic pressure p_c;
    what the chamber's contents take beyond the rigid oil's volume (air expanding below
    the charge, vapour) is oil the rebound chamber does not take, so it goes to the gas
    side, and p_c rises by the gas law, (V/(V - ΔV))^n (a cavitating chamber's saturated
    force is p_c A_piston, so this is its level). None: p_c as given. `dp_scale`: per
    sample, the factor a term applied to the algebraic solve's Δp (the flow law is taken
    at Δp / scale, so a rigid chamber gives the same Δp); None: 1. `valve_laminar`: the
    stacks' seat land λ_v per sample (model/flow.py); None: sharp-edged openings.
    """
    use_carry = carry is not None and starts.size == 1
    # (p, vapour, Δp, the step before's p and vapour, the released gas now and before)
    cin = np.array([math.nan] * 5 + [0.0, 0.0])
    if use_carry:
        assert carry is not None
        got = np.asarray(carry, dtype=float)
        cin[: min(got.size, 7)] = got[:7]  # a 3-state carry: the next step is Euler's
    lam = np.zeros(x.size) if bleed_laminar is None else bleed_laminar
    gas = np.zeros(x.size) if gas_volume is None else gas_volume
    sc = np.ones(x.size) if dp_scale is None else dp_scale
    vlam = np.zeros(x.size) if valve_laminar is None else valve_laminar
    guides = _GUIDES.get()
    layout: Layout = (
        x.size,
        np.asarray(starts).tobytes(),
        np.asarray(dt_s).tobytes(),
        periodic,
    )
    guide = guides.get(layout) if guides is not None and not use_carry else None
    g_pre, g_fin, g_used = guide if guide is not None else (_NONE, _NONE, _NO_PASSES)
    k = _constants_of(spec, chamber, gas_index)
    bleeds = (bleed_compression_m2, bleed_rebound_m2)
    arrays = (x, v, p_c, dp_static, *bleeds, k_leak, lam, sc, gas, vlam)
    smp = Samples(*(_per_sample(a, x.size) for a in arrays))
    dp, vap, pce, state, p_pre, p_fin, used, gas_out = _recent_run(
        smp,
        np.ascontiguousarray(starts, dtype=np.int64),
        np.ascontiguousarray(dt_s, dtype=float),
        k,
        periodic,
        cin,
        use_carry,
        Guide(g_pre, g_fin, g_used),
    )
    if guides is not None and guide is None and not use_carry:
        guides[layout] = (p_pre, p_fin, used)
    return dp, vap, pce, state, gas_out


def _constants_of(spec: DamperSpec, chamber: Chamber, gas_index: float) -> Constants:
    """What a whole integration holds fixed: the valves, the orifice constant, the areas,
    the chamber's contents and the gas index, as one `CONSTANTS` record."""
    valves = np.array([_valve_row(spec.compression_valve), _valve_row(spec.rebound_valve)])
    floor = chamber.release_pa
    return constants(
        valves=valves,
        c=spec.discharge_coefficient * math.sqrt(2.0 / spec.oil_density_kg_m3),
        a_q=spec.annulus_area_m2 - spec.couette_area_m2,
        a_r=spec.annulus_area_m2,
        length=chamber.length_m,
        air0=chamber.air_fraction * spec.annulus_area_m2 * chamber.length_m,
        p0=chamber.charge_pa,
        c_oil=chamber.oil_compressibility_per_pa,
        floor=floor if math.isfinite(floor) else -1.0e300,
        has_floor=math.isfinite(floor),
        r_form=chamber.form_resistance_pa_s_m3,
        r_cond=chamber.condense_resistance_pa_s_m3,
        gas_n=gas_index,
        # Released gas needs a release pressure that is one (above vacuum): Boyle's volume
        # of gas at a floor below it would be no volume at all.
        release=chamber.gas_release_m3_s if math.isfinite(floor) and floor > 0.0 else 0.0,
        dissolve=1.0 / (ATMOSPHERE_PA * chamber.redissolve_s),
    )


_NONE = np.zeros(0)
_NO_PASSES = np.zeros(0, dtype=np.int64)
# Within `linearised`: per layout of samples (size, segments, steps), the chamber pressure
# of the first integration there, as a guide for the later ones.
# A layout: (size, segment starts' bytes, steps' bytes, periodic).
Layout = tuple[int, bytes, bytes, bool]
Guides = dict[Layout, tuple[FloatArray, FloatArray, NDArray[np.int64]]]
_GUIDES: ContextVar[Guides | None] = ContextVar("chamber_guides", default=None)


@contextmanager
def linearised() -> Iterator[Guides]:
    """Within this block, the first integration of a set of samples is solved as always
    and the later ones of the same samples (a Jacobian's columns: the model a small step
    away in one parameter) take one Newton step per chamber step from its trajectory:
    the perturbed step's root to first order in its distance from the first one's (the
    error is that distance squared times the balance's curvature, of the order of the
    column's own finite-difference error). A step near a kink of the balance (no flow,
    a valve cracking or at full lift, the release pressure, vapour) is solved in full;
    so is a segment the first integration needed more than its usual passes for. One
    balance a step instead of 2.3. The guide is the first integration's, whatever the
    cache held, so the results are a function of the inputs alone."""
    guides: Guides = {}
    token = _GUIDES.set(guides)
    try:
        yield guides  # empty after the block when no chamber integration was guided
    finally:
        _GUIDES.reset(token)


# The chamber's constants (what a whole integration holds fixed) are one record of the
# `CONSTANTS` dtype (a NumPy structured scalar, typed by numba as a record and passed by
# reference; `Constants` is what the type checker sees of it), not a dozen scalars each
# kernel takes. A jitclass would do as well in the loop, but numba cannot cache a
# function that takes one, and every process would compile the chamber anew. `Step` is
# what one implicit step adds (its inputs, interpolated between samples), a named tuple
# of floats built in the loop. The parts `_step` is split into are inlined into it
# (inline="always", in numba's own IR): compiled apart, each layer's LLVM module is
# optimised again with all it calls. They stay in this file with the loop: numba's cache
# of `_run` is invalidated by changes to this file only, not to a file it calls into.
CONSTANTS = np.dtype(
    [
        ("valves", np.float64, (2, 5)),  # compression, rebound: `_valve_row`
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
        ("release", np.float64),  # released gas: m³/s at 1 atm while vapour is held
        ("dissolve", np.float64),  # 1/(P_atm τ): its redissolution per Pa over the floor
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
    release: float
    dissolve: float


def constants(**fields: object) -> Constants:
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
    gas: float = 0.0  # released gas at the step's end, m³ at one atmosphere
    vlam: float = 0.0  # the stacks' seat land (0: sharp-edged openings)


# error_model="numpy" on every kernel of the loop (as in flow.py): numba's default tests each
# division's divisor to raise ZeroDivisionError, and those tests took about 30 % of the
# loop's time (benchmarks/bench_chamber.py: 0.70x, every output bit for bit the same). A
# zero divisor now gives inf or NaN, as in NumPy, which the iterations' finiteness tests
# and bisections already handle.
@njit(cache=True, error_model="numpy")
def _flow(
    d: float, a_b: float, valve: FloatArray, c: float, k_leak: float, lam: float, vlam: float
) -> tuple[float, float]:
    """q(d) and dq/dd for d >= 0 through one direction's bleed (with its laminar land λ,
    model/flow.py), shim stack (with its seat land λ_v) and leak."""
    perim, face, preload, stiff, lift_max = valve[0], valve[1], valve[2], valve[3], valve[4]
    lift = (d * face - preload) / stiff
    if vlam > 0.0:
        lift = 0.0  # the stack through its seat land is added apart below
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
        qb, dqb, _ = laminar_orifice(d, a_b * a_b, lam, c)
        q += qb
        slope += dqb
    if vlam > 0.0:
        qv, dqv = valve_land_flow(d, perim, face, preload, stiff, lift_max, c, vlam)
        q += qv
        slope += dqv
    return q, slope


@njit(cache=True, error_model="numpy")
def _signed_flow(d: float, s: Step, k: Constants) -> tuple[float, float]:
    """q and dq/dd through the piston at drop d, the flow law taken at d / sc: a term
    that scales the algebraic solve's Δp by sc (the oil's temperature) scales the drop
    each flow needs by the same."""
    sc = s.sc
    if sc == 1.0:  # as a rule: no term scaled the solve
        if d >= 0.0:
            return _flow(d, s.a_bc, k.valves[0], k.c, s.k_leak, s.lam, s.vlam)
        q, slope = _flow(-d, s.a_bt, k.valves[1], k.c, s.k_leak, s.lam, s.vlam)
        return -q, slope
    e = d / sc
    if e >= 0.0:
        q, slope = _flow(e, s.a_bc, k.valves[0], k.c, s.k_leak, s.lam, s.vlam)
        return q, slope / sc
    q, slope = _flow(-e, s.a_bt, k.valves[1], k.c, s.k_leak, s.lam, s.vlam)
    return -q, slope / sc


@njit(cache=True, error_model="numpy")
def _occupied(p: float, vol: float, gas: float, k: Constants) -> tuple[float, float]:
    """Volume the chamber's oil, air and released gas take up at pressure p (up to a
    constant), and its derivative (negative: compliance). The air is a fixed amount, air0
    of volume at p0 (isothermal), so its part is an exact differential: a cycle returns
    every bubble to its size and pumps no oil (an air volume scaled with the chamber's,
    V(x) α p₀/p², does not: around a loop in x and p it moves oil through the piston every
    cycle). The released gas, `gas` m³ at one atmosphere, is as isothermal (Boyle)."""
    air0 = k.air0
    pe = max(p, MIN_PRESSURE_PA)
    oil = max(vol - air0, 0.0)
    free = air0 * k.p0 + gas * ATMOSPHERE_PA
    occ = free / pe - oil * k.c_oil * p
    docc = -(free / (pe * pe) + oil * k.c_oil)
    return occ, docc


@njit(cache=True, error_model="numpy")
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
    occ_ref, _ = _occupied(k.p0, s.vol, 0.0, k)  # released gas, like vapour, is growth
    grow = occ_now - occ_ref + vapour
    cap = GAS_CAP * gas_volume
    if grow >= cap:  # beyond any damper: held, so the balance stays monotone
        return base * (gas_volume / (gas_volume - cap)) ** n, 0.0, 0.0
    ratio = gas_volume / (gas_volume - grow)
    pc = base * (ratio if n == 1.0 else ratio**n)  # isothermal: no power to take
    per_volume = n * pc / (gas_volume - grow)
    return pc, per_volume * docc, per_volume


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _balance(p: float, s: Step, k: Constants) -> tuple[float, float, float, float, float]:
    """(F, dF/dp, p_c, vapour, dp_c/dp) of a step ending at chamber pressure p (off the floor):
    F = V_vap,old + dt (Q - q(p_c - p)) - occ(p) + occ(p_old) - V_vap(p), the volume the
    step leaves unaccounted for. It rises strictly with p: q falls as p rises and p_c
    falls, the contents shrink, and less vapour forms or more condenses."""
    g, dg = 0.0, 0.0
    if k.has_floor:
        g, dg = _vapour_at(p, s.vap_old, s.dt, k)
    occ, docc = _occupied(p, s.vol, s.gas, k)
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _pinned(
    lo: float, lo_open: bool, hi: float, hi_open: bool, r: Reach, s: Step, k: Constants
) -> tuple[float, float]:
    """The bracket with each bound still open found by its doubling."""
    if lo_open:
        lo = _bound(r.lo_from, -1.0, r.width, s, k)
    if hi_open:
        hi = _bound(r.hi_from, 1.0, r.width, s, k)
    return lo, hi


@njit(cache=True, error_model="numpy")
def _floor_balance(vv: float, rest: float, s: Step, k: Constants) -> tuple[float, float, float]:
    """(G, dG/dV, p_c) of a step ending at the floor with vapour V:
    G(V) = V - rest - dt (Q - q(p_c(floor, V) - floor)), the volume left unaccounted for.
    It rises in V: more vapour shortens the gas column, p_c rises and so does the outflow."""
    floor = k.floor
    occ, docc = _occupied(floor, s.vol, s.gas, k)
    pc, _, dpc_dv = _gas(occ, docc, vv, s, k)
    q, dq = _signed_flow(pc - floor, s, k)
    return vv - rest - s.dt * (s.q_demand - q), 1.0 + s.dt * dq * dpc_dv, pc


@njit(cache=True, error_model="numpy", inline="always")
def _tolerance(s: Step) -> float:
    """Settled within 1e-12 of the step's flow, or within what the arithmetic resolves: the
    balance subtracts the chamber's contents (occ, of the order of the air's volume),
    which it cannot know better than a few ulps of them. At reversal (no flow) the first
    bound alone was below that rounding, so no iterate could meet it."""
    tol = 1.0e-12 * (abs(s.q_demand) * s.dt + 1.0e-12) + 1.0e-22
    tol += CONTENTS_ULPS * EPS * (abs(s.occ_old) + abs(s.vap_old) + abs(s.q_demand) * s.dt)
    return tol


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy", inline="always")
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
    occ_f, _ = _occupied(k.floor, s.vol, s.gas, k)
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


@njit(cache=True, error_model="numpy", inline="always")
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


@njit(cache=True, error_model="numpy", inline="always")
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


@njit(cache=True, error_model="numpy", inline="always")
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


# The loop's kernels take a few bundles, not two dozen scalars each: the chamber's
# constants one record (`CONSTANTS`) and, as named tuples (numba types them by
# their fields), `Samples` the per-sample inputs, `Guide` a trajectory from `linearised`,
# `Out` the per-sample results, `Segment` one segment's layout and `State` what one step
# hands the next. The parts `_run` is split into are inlined into it (inline="always", in
# numba's own IR): compiled apart, each layer's LLVM module was optimised again with all
# it calls, and the first compilation took 8.2 s of CPU where the unsplit kernel's took
# 5.0; inlined in a chain (run > segment > pass > sub-step), 6.6-7.7; inlined with the
# chain cut short (the parts called from `_run` and `_step` themselves), 5.7-5.9.
class Samples(NamedTuple):
    """The per-sample inputs of an integration, one array each."""

    x: FloatArray
    v: FloatArray
    p_c: FloatArray
    dp_static: FloatArray
    a_bc: FloatArray
    a_bt: FloatArray
    k_leak: FloatArray
    lam: FloatArray
    sc: FloatArray
    gas_volume: FloatArray
    vlam: FloatArray


class Guide(NamedTuple):
    """A first integration's trajectory (`linearised`): the chamber pressure per sample
    in a periodic segment's first (part) pass and in its last, and each segment's passes.
    Empty: no guide."""

    pre: FloatArray
    fin: FloatArray
    used: NDArray[np.int64]


class Out(NamedTuple):
    """Per sample: Δp, vapour, p_c, the pressures a guide is made of, and the released
    gas's volume at the chamber's pressure."""

    dp: FloatArray
    vap: FloatArray
    pce: FloatArray
    p_pre: FloatArray
    p_fin: FloatArray
    gas: FloatArray


class Segment(NamedTuple):
    """One segment's integration plan: samples `lo`..`hi`, the first integrated `i0`, `m` chamber
    steps a sample of spacing `dt` (s), whether a periodic segment is prerolled and whether its
    steps are guided (`linearised`)."""

    lo: int
    hi: int
    i0: int  # the first sample integrated (a periodic segment's preroll starts later)
    m: int  # chamber steps a sample
    dt: float  # between samples
    preroll: bool
    guided: bool


class State(NamedTuple):
    """What a step hands the next."""

    p: float
    vv: float  # vapour
    d: float  # Δp
    p_prev: float  # the step before's p and vapour, for BDF2 (NaN: none, Euler's next)
    vv_prev: float
    off: float  # guided: the departure from the guide's pressure
    gas: float  # released gas, m³ at one atmosphere
    gas_prev: float  # the step before's (BDF2: its contents)


@njit(cache=True, error_model="numpy")
def _smooth_around(d: float, reach: float, sc: float, valves: FloatArray) -> bool:
    """Whether the flow law is smooth within `reach` of the drop d: no change of
    direction, no valve cracking or reaching its full lift in between."""
    e, r = abs(d / sc), reach / sc
    if e <= r:
        return False
    valve = valves[0] if d > 0.0 else valves[1]
    face, preload, stiff, lift_max = valve[1], valve[2], valve[3], valve[4]
    crack = preload / face
    full = (stiff * lift_max + preload) / face
    return bool(abs(e - crack) > r and abs(e - full) > r)


@njit(cache=True, error_model="numpy", inline="always")
def _guided(g: float, s: Step, k: Constants) -> tuple[bool, float, float, float]:
    """One Newton step from the guide's pressure g: (whether it stands, p, vapour, p_c).
    It stands where it is small and the balance smooth about it (no kink within
    GUIDE_REACH of its length), off the floor and with no vapour."""
    f, df, pc_g, vv_g, dpc = _balance(g, s, k)
    delta = f / df if df > 0.0 else math.nan
    reach = GUIDE_REACH * abs(delta)
    if (
        math.isfinite(delta)
        and abs(delta) <= 1.0e-4 * (abs(g) + 1.0e3)
        and _smooth_around(pc_g - g, reach, s.sc, k.valves)
        and (not k.has_floor or (s.vap_old == 0.0 and g - reach > k.floor))
    ):
        return True, g - delta, vv_g, pc_g - dpc * delta
    return False, math.nan, math.nan, math.nan


@njit(cache=True, error_model="numpy", inline="always")
def _substep(
    smp: Samples,
    i: int,
    k0: int,
    w: float,
    h: float,
    st: State,
    guided: bool,
    g0: float,
    k: Constants,
) -> tuple[State, float]:
    """One chamber step of length h to the fraction w of the way from sample k0 to
    sample i (inputs interpolated linearly, the step's own at i): the state at its end,
    and p_c. BDF2 where the two steps before held no vapour, else backward Euler.
    Guided (`g0`: the guide's pressure at i), one Newton step from the guide's pressure
    moved as this state departs from the guide's, where that stands (`_guided`)."""
    xi = smp.x[k0] + w * (smp.x[i] - smp.x[k0])
    vi = smp.v[k0] + w * (smp.v[i] - smp.v[k0])
    base = smp.p_c[k0] + w * (smp.p_c[i] - smp.p_c[k0])
    vol = k.a_r * max(k.length + xi, 0.05 * k.length)
    gv = smp.gas_volume[k0] + w * (smp.gas_volume[i] - smp.gas_volume[k0])
    p, vv = st.p, st.vv
    gas = _released(st.gas, p, vv, h, k)
    occ_old, _ = _occupied(p, vol, st.gas, k)  # the gas this step releases is new volume
    guess = p
    if vv == 0.0 and st.vv_prev == 0.0 and math.isfinite(st.p_prev):
        occ_m, _ = _occupied(st.p_prev, vol, st.gas_prev, k)
        h, occ_old = 2.0 * h / 3.0, occ_old + (occ_old - occ_m) / 3.0
        # Newton's start on the line through the last two steps' ends (they are a step
        # apart) rather than at the last: 3.1 balances a step where it took 3.6
        # (aerated-oil sweep, 1.5 Hz).
        guess = 2.0 * p - st.p_prev
    s = Step(
        occ_old, vv, base, k.a_q * vi, h, vol, smp.a_bc[i], smp.a_bt[i], smp.k_leak[i],
        smp.lam[i], smp.sc[i], gv, gas, smp.vlam[i],
    )  # fmt: skip
    solve = True
    p_new, vv_new, pci = math.nan, math.nan, math.nan
    # Off the floor (and no vapour) only: the balance below the floor is a finite
    # formation's, or none. A shift common to both chambers (a gas charge's) moves p with
    # the drop unchanged, and the Newton step is then that departure's change, not the
    # whole shift.
    g = g0 + st.off if guided else math.nan
    if guided and not (k.has_floor and (vv != 0.0 or not g > k.floor)):
        stands, p_new, vv_new, pci = _guided(g, s, k)
        solve = not stands
    if solve and guided and math.isfinite(g):
        guess = g
    if solve:
        p_new, vv_new, pci = _step(guess, s, k)
    off = p_new - g0 if guided else st.off
    return State(p_new, vv_new, pci - p_new, p, vv, off, gas, st.gas), pci


@njit(cache=True, error_model="numpy", inline="always")
def _released(gas: float, p: float, vv: float, h: float, k: Constants) -> float:
    """The released gas (m³ at one atmosphere) after a step of length h from pressure p
    and vapour vv: while the chamber holds vapour, gas comes out into it at a fixed rate;
    above the floor it goes back into solution at G (p - p_v)/(P_atm τ) (implicit in G, so
    it never goes negative). Explicit in p and vv: the step's own balance then sees the
    gas as new volume (a release) or lost volume (redissolution) at its start."""
    if k.release <= 0.0 and gas <= 0.0:
        return gas
    if vv > 0.0:
        return gas + h * k.release
    if p > k.floor:
        return gas / (1.0 + h * (p - k.floor) * k.dissolve)
    return gas


@njit(cache=True, error_model="numpy", inline="always")
def _pass(
    smp: Samples,
    out: Out,
    seg: Segment,
    it: int,
    use_carry: bool,
    guide: FloatArray,
    st: State,
    k: Constants,
) -> State:
    """Pass `it` over a segment's samples from state st (the first pass from seg.i0):
    their results into `out`, and the state at the segment's end. Sub-steps of at most
    MAX_STEP_S between samples: a vapour volume's refill ends within a millisecond, which
    a fit's 5 ms samples would place a whole step late. The first sample of a periodic
    pass follows the segment's last; of a carried call, the last call's (inputs held)."""
    for i in range(seg.i0 if it == 0 else seg.lo, seg.hi):
        if i == seg.i0 and it == 0 and not use_carry:
            out.dp[i] = st.d  # the initial state is the first sample's
            out.vap[i] = st.vv
            out.pce[i] = smp.p_c[i]
            out.p_pre[i] = st.p
            out.p_fin[i] = st.p
            out.gas[i] = st.gas * ATMOSPHERE_PA / max(st.p, MIN_PRESSURE_PA)
            if seg.guided:
                st = State(
                    st.p, st.vv, st.d, st.p_prev, st.vv_prev, st.p - guide[i], st.gas,
                    st.gas_prev,
                )  # fmt: skip
            continue
        k0 = i - 1 if i > seg.lo else (seg.hi - 1 if it > 0 else i)
        g0 = guide[i] if seg.guided else math.nan
        pci = math.nan
        for j in range(1, seg.m + 1):
            st, pci = _substep(smp, i, k0, j / seg.m, seg.dt / seg.m, st, seg.guided, g0, k)
        out.dp[i] = st.d
        out.vap[i] = st.vv
        out.pce[i] = pci
        out.gas[i] = st.gas * ATMOSPHERE_PA / max(st.p, MIN_PRESSURE_PA)
        if seg.preroll and it == 0:
            out.p_pre[i] = st.p
        out.p_fin[i] = st.p
    return st


@njit(cache=True, error_model="numpy", inline="always")
def _layout(
    lo: int, hi: int, dt: float, periodic: bool, use_carry: bool, guide_passes: int
) -> tuple[Segment, int]:
    """A segment's layout, and the passes it may take. A periodic segment first runs its
    last quarter from that sample's static state (the chamber forgets in far less than a
    quarter cycle), so the full passes start from nearly the state the segment ends in:
    one full pass where that holds. Guided (`guide_passes`: the guide's, -1: none), the
    guide's passes where they are the least this segment takes (the part pass and one
    full), at one step a sample."""
    preroll = periodic and not use_carry and hi - lo >= 8
    i0 = hi - (hi - lo) // 4 if preroll else lo
    m = max(1, int(math.ceil(dt / MAX_STEP_S - 1e-9)))  # noqa: RUF046 (numba)
    least = 2 if preroll else 1
    guided = guide_passes == least and m == 1
    passes = (PERIODIC_PASSES + (1 if preroll else 0)) if periodic else 1
    if guided:
        passes = least
    return Segment(lo, hi, i0, m, dt, preroll, guided), passes


@njit(cache=True, error_model="numpy", inline="always")
def _start(smp: Samples, i0: int, carry: FloatArray, use_carry: bool, k: Constants) -> State:
    """A segment's first state: the carried one, or sample i0's static state (no vapour)."""
    if use_carry:
        return State(carry[0], carry[1], carry[2], carry[3], carry[4], 0.0, carry[5], carry[6])
    p = smp.p_c[i0] - smp.dp_static[i0]
    if k.has_floor and p < k.floor:
        p = k.floor
    return State(p, 0.0, smp.p_c[i0] - p, math.nan, math.nan, 0.0, 0.0, 0.0)


@njit(cache=True, error_model="numpy", inline="always")
def _done(seg: Segment, it: int, passes: int, start: State, st: State) -> bool:
    """Whether a segment's pass `it` (from `start` to `st`) is its last: a periodic pass
    that ends where it began (not the preroll's part pass, nor a guided segment's)."""
    if seg.guided or it + 1 >= passes or (seg.preroll and it == 0):
        return False
    close = abs(st.p - start.p) <= 1.0e-6 * (abs(start.p) + 1.0e3)
    gas = abs(st.gas - start.gas) <= 1.0e-6 * start.gas + 1.0e-18
    return close and abs(st.vv - start.vv) <= 1.0e-12 and gas


@njit(cache=True, error_model="numpy", inline="always")
def _gas_ahead(before: float, start: State, st: State) -> State:
    """`st` with its released gas moved to the fixed point of the cycle map the last two
    passes show (Aitken's Δ²: `before`, `start`.gas and `st`.gas each a pass apart). The
    gas redissolves over seconds, so a 1.5 Hz cycle's passes close on it at 0.25-0.7 of
    the gap a pass: four would leave a quarter of it. Where the map is contracting."""
    d1, d2 = start.gas - before, st.gas - start.gas
    if not (math.isfinite(before) and d1 != 0.0):
        return st
    a = d2 / d1
    if not 0.0 < a < 0.95:
        return st
    jump = d2 * a / (1.0 - a)
    return State(
        st.p, st.vv, st.d, st.p_prev, st.vv_prev, st.off, st.gas + jump,
        max(st.gas_prev + jump, 0.0),
    )  # fmt: skip


@njit(cache=True, error_model="numpy")
def _run(
    smp: Samples,
    starts: NDArray[np.int64],
    dt_s: FloatArray,
    k: Constants,
    periodic: bool,
    carry: FloatArray,
    use_carry: bool,
    guide: Guide,
) -> tuple[
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    NDArray[np.int64],
    FloatArray,
]:
    """(Δp, vapour, p_c, final state) per sample, and the trajectory a later call may be
    guided by (`linearised`): the chamber pressure per sample in a periodic segment's
    first (part) pass and in its last pass, and the passes each segment took (periodic:
    until one ends where it began). With a
    guide (guide.used not empty), a segment whose guide took as many passes as this one
    would at the least takes them, each step one Newton step from the guide's pressure
    where the balance is smooth about it."""
    n = smp.x.size
    out = Out(
        np.empty(n), np.empty(n), np.empty(n), np.full(n, math.nan), np.full(n, math.nan),
        np.empty(n),
    )  # fmt: skip
    nseg = starts.size
    used = np.zeros(nseg, dtype=np.int64)
    state = np.zeros(7)
    for j in range(nseg):
        lo = starts[j]
        hi = starts[j + 1] if j + 1 < nseg else n
        if hi <= lo:
            continue
        passes_of_guide = guide.used[j] if guide.used.size == nseg else -1
        seg, passes = _layout(lo, hi, dt_s[j], periodic, use_carry, passes_of_guide)
        st = _start(smp, seg.i0, carry, use_carry, k)
        # The passes here, not in a part of their own: numba copies an inlined part's
        # code into each caller, so a chain of them copies the innermost over and over.
        before = math.nan  # the released gas a full pass before `start` (`_gas_ahead`)
        for it in range(passes):
            start = st
            along = guide.pre if seg.preroll and it == 0 else guide.fin
            st = _pass(smp, out, seg, it, use_carry, along, st, k)
            used[j] = it + 1
            if _done(seg, it, passes, start, st):
                break
            if (seg.preroll and it == 0) or seg.guided or st.gas <= 0.0:
                continue
            if it + 1 < passes and math.isfinite(before):
                st = _gas_ahead(before, start, st)
                before = math.nan  # two passes from the moved gas before it moves again
            else:
                before = start.gas
        state[0] = st.p
        state[1] = st.vv
        state[2] = st.d
        state[3] = st.p_prev
        state[4] = st.vv_prev
        state[5] = st.gas
        state[6] = st.gas_prev
    return out.dp, out.vap, out.pce, state, out.p_pre, out.p_fin, used, out.gas


# A Jacobian column of a parameter that acts after the chamber repeats its inputs exactly,
# and a refit often returns to a point a few fits back: on the friction + air sweep of the
# suite, 878 of 5518 integrations repeated one of the last 2, 1187 of the last 8, 1696 of
# the last 16 (1931 of any before).
_recent_run = Recent(_run, size=16, max_bytes=128 << 20)
