"""The chamber's integration is its loop written out, bit for bit.

The kernel's loop (`_run`) is split into named parts (a segment's layout and first state,
its passes, a pass's samples, a sample's sub-steps, a guided step) that numba inlines.
Here the same loop is written out as one function in Python, calling the compiled step
(`_step`) and balance, and every output of the kernel must equal it bit for bit: the
arithmetic is the same IEEE double arithmetic in the same order, so any difference is a
part that does something else (an input taken at the wrong sample, a state handed on
wrong, a pass cut short)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest

from shockdyno.model import chamber as C
from shockdyno.model.spec import load_spec

SPEC = load_spec()


def reference_run(
    smp: C.Samples,
    starts: np.ndarray,
    dt_s: np.ndarray,
    k: C.Constants,
    periodic: bool,
    carry: np.ndarray,
    use_carry: bool,
    guide: C.Guide,
) -> tuple[Any, ...]:
    n = smp.x.size
    dp, vap, pce, gas_out = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    p_pre, p_fin = np.full(n, math.nan), np.full(n, math.nan)
    nseg = starts.size
    used = np.zeros(nseg, dtype=np.int64)
    state = np.zeros(7)
    for seg in range(nseg):
        lo = int(starts[seg])
        hi = int(starts[seg + 1]) if seg + 1 < nseg else n
        if hi <= lo:
            continue
        dt = dt_s[seg]
        preroll = periodic and not use_carry and hi - lo >= 8
        i0 = hi - (hi - lo) // 4 if preroll else lo
        m = max(1, math.ceil(dt / C.MAX_STEP_S - 1e-9))
        least = 2 if preroll else 1
        guided = guide.used.size == nseg and guide.used[seg] == least and m == 1
        p_prev, vv_prev, gas, gas_prev = math.nan, math.nan, 0.0, 0.0
        if use_carry:
            p, vv, d, p_prev, vv_prev, gas, gas_prev = carry
        else:
            p, vv = smp.p_c[i0] - smp.dp_static[i0], 0.0
            if k.has_floor and p < k.floor:
                p = k.floor
            d = smp.p_c[i0] - p
        passes = (C.PERIODIC_PASSES + (1 if preroll else 0)) if periodic else 1
        if guided:
            passes = least
        off = 0.0
        before = math.nan
        for it in range(passes):
            p_start, v_start, g_start = p, vv, gas
            along = guide.pre if preroll and it == 0 else guide.fin
            for i in range(i0 if it == 0 else lo, hi):
                if i == i0 and it == 0 and not use_carry:
                    dp[i], vap[i], pce[i], p_pre[i], p_fin[i] = d, vv, smp.p_c[i], p, p
                    gas_out[i] = gas * C.ATMOSPHERE_PA / max(p, C.MIN_PRESSURE_PA)
                    if guided:
                        off = p - along[i]
                    continue
                for j in range(1, m + 1):
                    w = j / m
                    k0 = i - 1 if i > lo else (hi - 1 if it > 0 else i)

                    def at(a: np.ndarray, k0: int = k0, i: int = i, w: float = w) -> Any:
                        return a[k0] + w * (a[i] - a[k0])

                    vol = k.a_r * max(k.length + at(smp.x), 0.05 * k.length)
                    h = dt / m
                    gas_new = gas
                    if k.release > 0.0 or gas > 0.0:
                        if vv > 0.0:
                            gas_new = gas + h * k.release
                        elif p > k.floor:
                            gas_new = gas / (1.0 + h * (p - k.floor) * k.dissolve)
                    occ_old = C._occupied(p, vol, gas, k)[0]
                    guess = p
                    if vv == 0.0 and vv_prev == 0.0 and math.isfinite(p_prev):
                        occ_m = C._occupied(p_prev, vol, gas_prev, k)[0]
                        h, occ_old = 2.0 * h / 3.0, occ_old + (occ_old - occ_m) / 3.0
                        guess = 2.0 * p - p_prev
                    p_prev, vv_prev, gas_prev, gas = p, vv, gas, gas_new
                    s = C.Step(
                        occ_old, vv, at(smp.p_c), k.a_q * at(smp.v), h, vol, smp.a_bc[i],
                        smp.a_bt[i], smp.k_leak[i], smp.lam[i], smp.sc[i], at(smp.gas_volume),
                        gas, smp.vlam[i],
                    )  # fmt: skip
                    solve = True
                    g = along[i] + off if guided else math.nan
                    if guided and not (k.has_floor and (vv != 0.0 or not g > k.floor)):
                        f, df, pc_g, vv_g, dpc = C._balance(g, s, k)
                        delta = f / df if df > 0.0 else math.nan
                        reach = C.GUIDE_REACH * abs(delta)
                        if (
                            math.isfinite(delta)
                            and abs(delta) <= 1.0e-4 * (abs(g) + 1.0e3)
                            and C._smooth_around(pc_g - g, reach, s.sc, k.valves)
                            and (not k.has_floor or (vv == 0.0 and g - reach > k.floor))
                        ):
                            p, vv, pci = g - delta, vv_g, pc_g - dpc * delta
                            solve = False
                    if solve and guided and math.isfinite(g):
                        guess = g
                    if solve:
                        p, vv, pci = C._step(guess, s, k)
                    d = pci - p
                    if guided:
                        off = p - along[i]
                dp[i], vap[i], pce[i] = d, vv, pci
                gas_out[i] = gas * C.ATMOSPHERE_PA / max(p, C.MIN_PRESSURE_PA)
                if preroll and it == 0:
                    p_pre[i] = p
                p_fin[i] = p
            used[seg] = it + 1
            if guided:
                continue
            if it + 1 < passes and not (preroll and it == 0):
                close = abs(p - p_start) <= 1.0e-6 * (abs(p_start) + 1.0e3)
                close_gas = abs(gas - g_start) <= 1.0e-6 * g_start + 1.0e-18
                if close and abs(vv - v_start) <= 1.0e-12 and close_gas:
                    break
            if (preroll and it == 0) or gas <= 0.0:
                continue
            if it + 1 < passes and math.isfinite(before):
                d1, d2 = g_start - before, gas - g_start
                a = d2 / d1 if d1 != 0.0 else math.nan
                if 0.0 < a < 0.95:
                    jump = d2 * a / (1.0 - a)
                    gas, gas_prev = gas + jump, max(gas_prev + jump, 0.0)
                before = math.nan
            else:
                before = g_start
        state[:] = p, vv, d, p_prev, vv_prev, gas, gas_prev
    return dp, vap, pce, state, p_pre, p_fin, used, gas_out


@contextmanager
def kernel_calls() -> Iterator[list[tuple[Any, ...]]]:
    """The arguments and results of every kernel call `integrate` makes within."""
    calls: list[tuple[Any, ...]] = []
    kept = C._recent_run

    def record(*args: Any) -> Any:
        out = C._run(*args)
        calls.append((args, out))
        return out

    C._recent_run = record  # type: ignore[assignment]
    try:
        yield calls
    finally:
        C._recent_run = kept


def sweep(freqs: tuple[float, ...], dt: float) -> tuple[Any, ...]:
    """Sinusoidal segments of one cycle each, 25 mm; their Δp a smooth law of v."""
    xs, vs, starts = [], [], []
    for f in freqs:
        t = np.arange(int(1.0 / f / dt)) * dt
        starts.append(sum(a.size for a in xs))
        xs.append(0.025 * np.sin(2 * np.pi * f * t))
        vs.append(0.025 * 2 * np.pi * f * np.cos(2 * np.pi * f * t))
    x, v = np.concatenate(xs), np.concatenate(vs)
    n = x.size
    p_c = SPEC.gas_pressure_pa * (1 + 0.2 * x / 0.025)
    dp_static = 2.5e6 * np.tanh(v / 0.15)
    return (
        x, v, p_c, dp_static, np.full(n, 2e-6), np.full(n, 1e-6), np.full(n, 4.7e-13),
        np.array(starts, dtype=np.intp), np.full(len(freqs), dt),
    )  # fmt: skip


def chamber(air: float = 0.0, oil: float = 0.0, floor: float = -math.inf, **kw: float) -> Any:
    return C.Chamber(air, SPEC.gas_pressure_pa, oil, floor, SPEC.oil_column_m, **kw)


CASES: dict[str, tuple[Any, tuple[float, ...], float, bool, dict[str, Any]]] = {
    # name: chamber, frequencies, sample step, periodic, integrate's keywords
    "aerated, periodic": (chamber(air=0.01, oil=1 / 1.5e9), (1.0, 2.0), 1e-3, True, {}),
    "oil only, periodic sub-steps": (chamber(oil=1 / 0.7e9), (2.0, 4.0), 2.5e-3, True, {}),
    "vapour, hard floor": (chamber(air=0.003, floor=1.3e6), (2.0, 3.0), 1e-3, True, {}),
    "vapour, finite rates, sub-steps": (
        chamber(floor=1.3e6, form_resistance_pa_s_m3=3e10, condense_resistance_pa_s_m3=1e11),
        (2.0, 4.0),
        5e-3,
        False,
        {},
    ),
    "vapour, released gas, sub-steps": (
        chamber(
            air=0.002,
            floor=1.3e6,
            gas_release_m3_s=2e-6,
            redissolve_s=3.0,
            condense_resistance_pa_s_m3=1e11,
        ),
        (1.5, 3.0),
        2e-3,
        True,
        {"gas_volume": 5.8e-5, "gas_index": 1.3},
    ),
    "warm oil, laminar bleed, gas column": (
        chamber(air=0.005),
        (1.5,),
        1e-3,
        True,
        {"dp_scale": 0.9, "bleed_laminar": 2e-8, "gas_volume": 5.8e-5, "gas_index": 1.3},
    ),
    "aerated, stacks with a seat land": (
        chamber(air=0.005),
        (1.5,),
        1e-3,
        True,
        {"valve_laminar": 1.1e-4},
    ),
}


def per_sample(kw: dict[str, Any], n: int) -> dict[str, Any]:
    return {k: v if k == "gas_index" else np.full(n, v) for k, v in kw.items()}


@pytest.mark.parametrize("case", list(CASES))
def test_the_kernel_is_its_loop_written_out(case: str) -> None:
    ch, freqs, dt, periodic, kw = CASES[case]
    args = sweep(freqs, dt)
    extra = per_sample(kw, args[0].size)
    with kernel_calls() as calls:
        C.integrate(SPEC, ch, *args, periodic, **extra)
        with C.linearised():  # the second a guided column of the first
            C.integrate(SPEC, ch, *args, periodic, **extra)
            moved = list(args)
            moved[2] = args[2] * (1 + 1e-6)
            C.integrate(SPEC, ch, *moved, periodic, **extra)
    assert len(calls) == 3
    assert calls[2][0][-1].used.size > 0  # the last was given a guide
    for kernel_args, got in calls:
        want = reference_run(*kernel_args)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)
    if calls[0][0][3].has_floor:
        assert np.max(calls[0][1][1]) > 0  # the floor was reached: vapour formed
    if calls[0][0][3].release > 0:
        assert np.min(calls[0][1][7]) > 0  # gas was released, and outlived the void


@pytest.mark.parametrize("states", [3, 5, 7])
def test_a_carried_state_is_taken_up_as_written_out(states: int) -> None:
    """One segment carried on from an earlier call: a 3-state carry (no step before: the
    first step is Euler's), a 5-state one (BDF2 from the first) and a 7-state one (the
    released gas too)."""
    x, v, p_c, dp_static, a_bc, a_bt, k_leak, _, _ = sweep((2.0,), 1e-3)
    one = np.zeros(1, dtype=np.intp)
    first = C.integrate(
        SPEC, chamber(air=0.01), x, v, p_c, dp_static, a_bc, a_bt, k_leak, one,
        np.array([1e-3]), False,
    )  # fmt: skip
    with kernel_calls() as calls:
        C.integrate(
            SPEC, chamber(air=0.01), x, v, p_c, dp_static, a_bc, a_bt, k_leak, one,
            np.array([1e-3]), False, first[3][:states],
        )  # fmt: skip
    ((kernel_args, got),) = calls
    assert kernel_args[6]  # use_carry
    for a, b in zip(got, reference_run(*kernel_args), strict=True):
        np.testing.assert_array_equal(a, b)


def test_the_record_and_what_the_type_checker_sees_name_the_same_fields() -> None:
    """`Constants` (typing only) must name the `CONSTANTS` record's fields: a field added
    to one alone would be read by the kernels unchecked, or checked and never there."""
    assert list(C.Constants.__annotations__) == list(C.CONSTANTS.names)
    k = C.constants(air0=2.0, has_floor=True)
    assert (k.air0, k.has_floor, k.valves.shape, k.gas_n) == (2.0, True, (2, 5), 0.0)
