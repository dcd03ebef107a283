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
One step's balance and its solve are model/chamber_step.py; this module is the loop.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from shockdyno.model.chamber_step import Constants, Step, _balance, _occupied, _step, constants
from shockdyno.model.recent import Recent
from shockdyno.model.shims import ShimStack
from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

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

    @property
    def rigid(self) -> bool:
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
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(Δp, vapour volume m³, compression-chamber pressure, final state) for every sample,
    segment by segment.

    A segment starts in the static state (Δp = dp_static, no vapour) unless `carry`
    (single segment: the previous call's final state) is given, or `periodic` (whole
    cycles in their steady state: the state it ends in, found by repeating it).
    `gas_volume`: the gas column's volume per sample (m³) at the algebraic pressure p_c;
    what the chamber's contents take beyond the rigid oil's volume (air expanding below
    the charge, vapour) is oil the rebound chamber does not take, so it goes to the gas
    side, and p_c rises by the gas law, (V/(V - ΔV))^n (a cavitating chamber's saturated
    force is p_c A_piston, so this is its level). None: p_c as given. `dp_scale`: per
    sample, the factor a term applied to the algebraic solve's Δp (the flow law is taken
    at Δp / scale, so a rigid chamber gives the same Δp); None: 1.
    """
    valves = np.array([_valve_row(spec.compression_valve), _valve_row(spec.rebound_valve)])
    c = spec.discharge_coefficient * math.sqrt(2.0 / spec.oil_density_kg_m3)
    a_q = spec.annulus_area_m2 - spec.couette_area_m2
    use_carry = carry is not None and starts.size == 1
    cin = np.full(5, math.nan)  # (p, vapour, Δp, and the step before's p and vapour)
    if use_carry:
        assert carry is not None
        got = np.asarray(carry, dtype=float)
        cin[: min(got.size, 5)] = got[:5]  # a 3-state carry: the next step is Euler's
    floor = chamber.release_pa
    lam = np.zeros(x.size) if bleed_laminar is None else bleed_laminar
    gas = np.zeros(x.size) if gas_volume is None else gas_volume
    sc = np.ones(x.size) if dp_scale is None else dp_scale
    guides = _GUIDES.get()
    layout = (x.size, np.asarray(starts).tobytes(), np.asarray(dt_s).tobytes(), periodic)
    guide = guides.get(layout) if guides is not None and not use_carry else None
    g_pre, g_fin, g_used = guide if guide is not None else (_NONE, _NONE, _NO_PASSES)
    k = constants(
        valves=valves,
        c=c,
        a_q=a_q,
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
    )
    arrays = (x, v, p_c, dp_static, bleed_compression_m2, bleed_rebound_m2, k_leak, lam, sc, gas)
    smp = Samples(*(_per_sample(a, x.size) for a in arrays))
    dp, vap, pce, state, p_pre, p_fin, used = _recent_run(
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
    return dp, vap, pce, state


_NONE = np.zeros(0)
_NO_PASSES = np.zeros(0, dtype=np.int64)
# Within `linearised`: per layout of samples (size, segments, steps), the chamber pressure
# of the first integration there, as a guide for the later ones.
_GUIDES: ContextVar[dict[Any, tuple[FloatArray, FloatArray, NDArray[np.int64]]] | None] = (
    ContextVar("chamber_guides", default=None)
)


@contextmanager
def linearised() -> Iterator[dict[Any, Any]]:
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
    guides: dict[Any, Any] = {}
    token = _GUIDES.set(guides)
    try:
        yield guides  # empty after the block when no chamber integration was guided
    finally:
        _GUIDES.reset(token)


# The loop's kernels take a few bundles, not two dozen scalars each: the chamber's
# constants one record (chamber_step.CONSTANTS) and, as named tuples (numba types them by
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


class Guide(NamedTuple):
    """A first integration's trajectory (`linearised`): the chamber pressure per sample
    in a periodic segment's first (part) pass and in its last, and each segment's passes.
    Empty: no guide."""

    pre: FloatArray
    fin: FloatArray
    used: NDArray[np.int64]


class Out(NamedTuple):
    """Per sample: Δp, vapour, p_c, and the pressures a guide is made of."""

    dp: FloatArray
    vap: FloatArray
    pce: FloatArray
    p_pre: FloatArray
    p_fin: FloatArray


class Segment(NamedTuple):
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


@njit(cache=True)
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


@njit(cache=True, inline="always")
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


@njit(cache=True, inline="always")
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
    occ_old, _ = _occupied(p, vol, k)
    guess = p
    if vv == 0.0 and st.vv_prev == 0.0 and math.isfinite(st.p_prev):
        occ_m, _ = _occupied(st.p_prev, vol, k)
        h, occ_old = 2.0 * h / 3.0, occ_old + (occ_old - occ_m) / 3.0
        # Newton's start on the line through the last two steps' ends (they are a step
        # apart) rather than at the last: 3.1 balances a step where it took 3.6
        # (aerated-oil sweep, 1.5 Hz).
        guess = 2.0 * p - st.p_prev
    s = Step(
        occ_old, vv, base, k.a_q * vi, h, vol, smp.a_bc[i], smp.a_bt[i], smp.k_leak[i],
        smp.lam[i], smp.sc[i], gv,
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
    return State(p_new, vv_new, pci - p_new, p, vv, off), pci


@njit(cache=True, inline="always")
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
            if seg.guided:
                st = State(st.p, st.vv, st.d, st.p_prev, st.vv_prev, st.p - guide[i])
            continue
        k0 = i - 1 if i > seg.lo else (seg.hi - 1 if it > 0 else i)
        g0 = guide[i] if seg.guided else math.nan
        pci = math.nan
        for j in range(1, seg.m + 1):
            st, pci = _substep(smp, i, k0, j / seg.m, seg.dt / seg.m, st, seg.guided, g0, k)
        out.dp[i] = st.d
        out.vap[i] = st.vv
        out.pce[i] = pci
        if seg.preroll and it == 0:
            out.p_pre[i] = st.p
        out.p_fin[i] = st.p
    return st


@njit(cache=True, inline="always")
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


@njit(cache=True, inline="always")
def _start(smp: Samples, i0: int, carry: FloatArray, use_carry: bool, k: Constants) -> State:
    """A segment's first state: the carried one, or sample i0's static state (no vapour)."""
    if use_carry:
        return State(carry[0], carry[1], carry[2], carry[3], carry[4], 0.0)
    p = smp.p_c[i0] - smp.dp_static[i0]
    if k.has_floor and p < k.floor:
        p = k.floor
    return State(p, 0.0, smp.p_c[i0] - p, math.nan, math.nan, 0.0)


@njit(cache=True, inline="always")
def _done(seg: Segment, it: int, passes: int, start: State, st: State) -> bool:
    """Whether a segment's pass `it` (from `start` to `st`) is its last: a periodic pass
    that ends where it began (not the preroll's part pass, nor a guided segment's)."""
    if seg.guided or it + 1 >= passes or (seg.preroll and it == 0):
        return False
    close = abs(st.p - start.p) <= 1.0e-6 * (abs(start.p) + 1.0e3)
    return close and abs(st.vv - start.vv) <= 1.0e-12


@njit(cache=True)
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
    FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int64]
]:
    """(Δp, vapour, p_c, final state) per sample, and the trajectory a later call may be
    guided by (`linearised`): the chamber pressure per sample in a periodic segment's
    first (part) pass and in its last pass, and the passes each segment took (periodic:
    until one ends where it began). With a
    guide (guide.used not empty), a segment whose guide took as many passes as this one
    would at the least takes them, each step one Newton step from the guide's pressure
    where the balance is smooth about it."""
    n = smp.x.size
    out = Out(np.empty(n), np.empty(n), np.empty(n), np.full(n, math.nan), np.full(n, math.nan))
    nseg = starts.size
    used = np.zeros(nseg, dtype=np.int64)
    state = np.zeros(5)
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
        for it in range(passes):
            start = st
            along = guide.pre if seg.preroll and it == 0 else guide.fin
            st = _pass(smp, out, seg, it, use_carry, along, st, k)
            used[j] = it + 1
            if _done(seg, it, passes, start, st):
                break
        state[0] = st.p
        state[1] = st.vv
        state[2] = st.d
        state[3] = st.p_prev
        state[4] = st.vv_prev
    return out.dp, out.vap, out.pce, state, out.p_pre, out.p_fin, used


# A Jacobian column of a parameter that acts after the chamber repeats its inputs exactly,
# and a refit often returns to a point a few fits back: on the friction + air sweep of the
# suite, 878 of 5518 integrations repeated one of the last 2, 1187 of the last 8, 1696 of
# the last 16 (1931 of any before).
_recent_run = Recent(_run, size=16, max_bytes=128 << 20)
