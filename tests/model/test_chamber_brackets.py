"""The chamber's implicit step finds its bracket only when Newton's iteration needs it.

The step used to pin a lower and an upper bound by doubling before iterating: two
evaluations of the balance a step, and a third to return the settled pressure's state.
Both are now found lazily and the settled state kept. Every decision of the safeguarded
iteration is unchanged by that, so the step must be the same bit for bit as the eager
order's, written out here from the chamber's own balance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shockdyno.model import chamber as C
from shockdyno.model.spec import load_spec


def eager_step(p_guess: float, s: C.Step, k: C.Constants) -> tuple[float, float, float]:
    """The step with both bounds found by doubling first, then Newton (a step must halve
    the last; one taken after a Newton step whose length and rate put its end within
    tolerance ends the iteration unconfirmed), then one more call if none settled."""
    lo, hi = -math.inf, math.inf
    if k.air0 > 0.0:  # air0: the air takes any volume as p falls to nothing
        lo = C.MIN_PRESSURE_PA
    width = max(abs(p_guess) * 0.1, 1.0e3)
    if not math.isfinite(lo):
        lo = min(p_guess, hi) - width
        for _ in range(200):
            if C._balance(lo, s, k)[0] < 0.0:
                break
            width *= 2.0
            lo -= width
    if not math.isfinite(hi):
        width = max(abs(p_guess) * 0.1, 1.0e3)
        hi = max(p_guess, lo) + width
        for _ in range(200):
            if C._balance(hi, s, k)[0] > 0.0:
                break
            width *= 2.0
            hi += width
    p = min(max(p_guess, lo), hi)
    if not lo < p < hi:
        p = 0.5 * (lo + hi)
    tol = 1.0e-12 * (abs(s.q_demand) * s.dt + 1.0e-12) + 1.0e-22
    tol += C.CONTENTS_ULPS * C.EPS * (abs(s.occ_old) + abs(s.vap_old) + abs(s.q_demand) * s.dt)
    moved = newton = math.inf
    for _ in range(C.MAX_NEWTON):
        f, df, pc, _, dpc = C._balance(p, s, k)
        if abs(f) <= tol:
            break
        if f > 0.0:
            hi = p
        else:
            lo = p
        step = p - f / df if df > 0.0 else math.nan
        if not (lo < step < hi) or not math.isfinite(step) or abs(step - p) > 0.5 * moved:
            step = 0.5 * (lo + hi)
            newton = math.inf
        elif newton < math.inf and abs(step - p) ** 2 * df <= tol * newton:
            return step, 0.0, pc + dpc * (step - p)  # a Newton step taken unconfirmed
        else:
            newton = abs(step - p)
        moved = abs(step - p)
        p = step
        if hi - lo <= 1.0e-12 * (abs(p) + 1.0):
            break
    _, _, pc, vv, _ = C._balance(p, s, k)
    return p, vv, pc


@pytest.mark.parametrize("air", [0.0, 1.0e-4, 0.01])
def test_a_lazy_bracket_gives_the_eager_step_bit_for_bit(air: float) -> None:
    spec = load_spec(None)
    valves = np.array([C._valve_row(spec.compression_valve), C._valve_row(spec.rebound_valve)])
    c = spec.discharge_coefficient * math.sqrt(2.0 / spec.oil_density_kg_m3)
    rng = np.random.default_rng(7)
    p0 = spec.gas_pressure_pa
    vol = spec.annulus_area_m2 * 0.1
    air0 = air * vol
    far = 0
    for _ in range(400):
        base = p0 * rng.uniform(0.8, 1.5)
        dt = rng.choice([2.0e-4, 1.0e-3])
        q = rng.normal(0.0, 3.0e-4)  # the flow demand, m³/s
        c_oil = rng.choice([0.0, 1.0 / 1.6e9])
        if air0 == 0.0 and c_oil == 0.0:
            c_oil = 1.0 / 0.7e9
        # Guesses from near the root to far from it, so that Newton's steps leave the
        # first doubling's reach and the bounds must be found.
        p_guess = base * rng.uniform(-2.0, 3.0) if rng.random() < 0.5 else base * 0.98
        p_old = base * rng.uniform(0.5, 1.2)
        k = C.constants(
            valves=valves, c=c, air0=air0, p0=p0, c_oil=c_oil, floor=-1.0e300, gas_n=1.0
        )
        occ_old, _ = C._occupied(p_old, vol, 0.0, k)
        area = rng.choice([1.0e-7, 1.0e-6, 5.0e-6])
        s = C.Step(
            occ_old, 0.0, base, q, dt, vol, area, area * rng.uniform(0.3, 3.0), 1.0e-12,
            rng.uniform(0.0, 1.0), 1.0, 0.0,
        )  # fmt: skip
        want = eager_step(p_guess, s, k)
        got = C._step(p_guess, s, k)
        assert got == want, (p_guess, s[2:5], got, want)
        width = max(abs(p_guess) * 0.1, 1.0e3)
        far += not (p_guess - width < want[0] < p_guess + width)
    assert far > 50  # the lazy bounds were needed, not just never asked for
