"""The chamber's implicit step ends at its balance's root, also at reversal.

At a reversal the flow demand passes through zero and the flow law turns from one valve's
√Δp to the other's. There Newton's iteration could cycle between the two sides of the
root, each step landing just inside the bracket, and the step ended after its 100
iterations some 350 Pa off the root on one side or the other, by the parity of the count:
Δp came out 404 or 41 Pa depending on the ninth digit of the air fraction, and a fit's
Jacobian column of the air was that jump over its step. The inputs below are such a step,
taken from a fit of the simulated rig's aerated-oil sweep (clicks 3, 1.5 Hz, top reversal).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from shockdyno.model import chamber as C
from shockdyno.model.spec import load_spec

VALVES = np.array(
    [
        [0.11309733552923254, 0.0002011068235659518, 96.91787459818244, 642362.200451955, 4e-4],
        [0.10053096491487339, 0.00016003757991667908, 182.71808128500487, 1141780.5180952973, 4e-4],
    ]
)


def constants(air0: float, c_oil: float) -> C.Constants:
    return C.constants(
        valves=VALVES,
        c=0.03395498750508662,  # C_d √(2/ρ)
        air0=air0,  # air at p₀
        p0=1599689.856274119,
        c_oil=c_oil,
        floor=-1.0e300,  # no floor
        has_floor=False,
        gas_n=1.0,
    )


P_GUESS = 1721498.585692132  # the step before's pressure
AT_REVERSAL = C.Step(
    occ_old=1.5029332772631335e-06,
    vap_old=0.0,
    base=1726561.3757165684,  # p_c
    q_demand=7.489582251532782e-07,  # m³/s
    dt=0.000666666666660376,  # BDF2's 2/3 of a 1 ms step
    vol=0.00012129137885999485,  # the chamber's volume
    a_bc=4.868633804273402e-06,
    a_bt=9.627307175103726e-07,
    k_leak=4.724988950920478e-13,
    lam=0.0,  # laminar land
    sc=1.0,  # Δp scale
    gas_volume=5.8214481561219004e-05,
)
AIR0 = 1.7658941993065827e-06
C_OIL = 6.666666666666666e-10


def _root(s: C.Step, k: C.Constants) -> float:
    return float(brentq(lambda p: C._balance(p, s, k)[0], 1.0e6, 3.0e6, xtol=1e-9, rtol=1e-15))


def test_the_step_at_reversal_ends_at_its_root() -> None:
    k = constants(AIR0, C_OIL)
    p, _, pc = C._step(P_GUESS, AT_REVERSAL, k)
    root = _root(AT_REVERSAL, k)
    assert p == pytest.approx(root, abs=1e-6)
    assert pc - p == pytest.approx(40.708, abs=0.01)  # was 404.05: a 2-cycle's end


def test_dp_moves_smoothly_with_the_air() -> None:
    """Δp against the air in relative moves of 1e-9 to 1e-6 (a Jacobian's step is 1e-6):
    a smooth curve, no jump (second differences are the curvature's: 0.2 % of the first
    at 1e-6; a jump between the cycle's ends would be 360 Pa on a first of 0.17 Pa)."""
    for rel in (1e-9, 1e-8, 1e-7, 1e-6):
        ends = [
            C._step(P_GUESS, AT_REVERSAL, constants(AIR0 * (1 + j * rel), C_OIL))
            for j in range(-5, 6)
        ]
        dp = np.array([pc - p for p, _, pc in ends])
        first, second = np.diff(dp), np.diff(dp, 2)
        assert np.all(first < 0), (rel, dp)  # more air, less Δp here: monotone
        assert np.max(np.abs(second)) <= 0.01 * np.max(np.abs(first)), (rel, dp)


@pytest.mark.parametrize("air", [0.0, 1.0e-3, 0.02])
def test_steps_near_reversal_end_at_their_roots(air: float) -> None:
    """Random steps with the flow demand about zero (both valves within reach): each ends
    within a micropascal of its root, or on a balance within rounding of zero."""
    spec = load_spec(None)
    valves = np.array([C._valve_row(spec.compression_valve), C._valve_row(spec.rebound_valve)])
    c = spec.discharge_coefficient * math.sqrt(2.0 / spec.oil_density_kg_m3)
    rng = np.random.default_rng(11)
    vol = spec.annulus_area_m2 * 0.11
    p0 = spec.gas_pressure_pa
    c_oil = 1.0 / 1.5e9
    k = C.constants(
        valves=valves, c=c, air0=air * vol, p0=p0, c_oil=c_oil, floor=-1.0e300, gas_n=1.0
    )
    for _ in range(300):
        base = p0 * rng.uniform(0.9, 1.2)
        p_old = base + rng.normal(0.0, 2e3)
        occ_old, _ = C._occupied(p_old, vol, 0.0, k)
        s = C.Step(
            occ_old, 0.0, base, rng.normal(0.0, 2e-6), rng.choice([2e-4, 6.667e-4, 1e-3]), vol,
            rng.uniform(1e-7, 6e-6), rng.uniform(1e-7, 6e-6), 4.7e-13, 0.0, 1.0, 5.8e-5,
        )  # fmt: skip
        p, _, _ = C._step(p_old, s, k)
        assert p == pytest.approx(_root(s, k), abs=1e-6), s[2:5]
