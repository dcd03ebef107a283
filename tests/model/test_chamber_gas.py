"""The chamber's released gas against cases worked by hand.

Held at its floor p_v with vapour, the chamber gives up gas at a fixed rate ṅ (m³/s at
one atmosphere): after a time t it holds G = ṅ t, which takes G P_atm / p_v there (Boyle).
At the floor the void the flow leaves is the same whatever fills it, so the vapour is
that much less than without the gas. Above the floor the gas goes back at
G (p - p_v)/(P_atm τ): held at p for t, G = G₀ e^{-t (p - p_v)/(P_atm τ)}."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from shockdyno.model import DamperModel, ModelInputs
from shockdyno.model import chamber as C
from shockdyno.model.spec import load_spec
from shockdyno.model.terms import make_term

SPEC = load_spec().with_values({"gas_pressure_pa": 5.0e5})
FLOOR = 80e3  # Pa absolute: an oil filled without degassing
RATE = 2.0e-6  # m³/s at one atmosphere: 2 cm³/s
DT = 1e-3


def held_at_floor(rate: float, n: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """(vapour, gas's volume) per sample: a steady compression at 0.5 m/s through nearly
    closed bleeds, far more than the piston passes at p_c - p_v, so the rebound chamber
    sits at its floor from the first step on."""
    v = np.full(n, 0.5)
    x = -0.02 + v * DT * np.arange(n)
    p_c = np.full(n, SPEC.gas_pressure_pa)
    chamber = C.Chamber(0.0, SPEC.gas_pressure_pa, 0.0, FLOOR, SPEC.oil_column_m, 0.0, 0.0, rate)
    dp, vapour, _, _, gas = C.integrate(
        SPEC, chamber, x, v, p_c, np.full(n, 2e6), np.full(n, 1e-9), np.full(n, 1e-9),
        np.zeros(n), np.zeros(1, dtype=np.intp), np.array([DT]), False,
    )  # fmt: skip
    np.testing.assert_allclose(p_c - dp, FLOOR)  # held at the floor throughout
    return vapour, gas


def test_gas_released_at_a_rate_for_a_time_at_the_floor_takes_its_boyle_volume() -> None:
    vapour, gas = held_at_floor(RATE)
    plain, none = held_at_floor(0.0)
    assert np.all(none == 0.0) and np.all(np.diff(plain) > 0)  # a void that grows
    # The first step forms the void; the gas comes out from the next one on (its release
    # is explicit in the vapour at a step's start): (i - 1) steps of it by sample i.
    i = np.arange(1, vapour.size)
    by_hand = RATE * (i - 1) * DT * 101_325.0 / FLOOR
    np.testing.assert_allclose(gas[1:], by_hand, rtol=1e-12, atol=1e-18)
    assert gas[-1] == pytest.approx(RATE * 0.198 * 101_325.0 / FLOOR)  # 0.50 cm³ at 80 kPa
    # The void is the same whatever fills it: the vapour is less by the gas's volume.
    np.testing.assert_allclose(vapour + gas, plain, rtol=1e-9)


def test_released_gas_redissolves_over_its_time_at_a_held_pressure() -> None:
    """The law alone (`_released`), the pressure held 4 bar over the floor for 0.5 s at
    τ = 2 s: G₀ e^{-0.5 · 4e5 / (P_atm · 2)}, to the first order of the 1 ms step."""
    k = C.constants(floor=FLOOR, has_floor=True, release=RATE, dissolve=1 / (101_325.0 * 2.0))
    g0, p = 1e-7, FLOOR + 4e5
    g = g0
    for _ in range(500):
        g = C._released(g, p, 0.0, DT, k)
    rate = 4e5 / (101_325.0 * 2.0)
    assert g == pytest.approx(g0 * math.exp(-0.5 * rate), rel=0.5 * rate * DT * 1.1)
    assert g == pytest.approx(g0 / (1 + DT * rate) ** 500, rel=1e-12)  # implicit Euler
    assert C._released(g0, FLOOR, 0.0, DT, k) == g0  # at the floor, no vapour: it stays
    assert C._released(g0, FLOOR, 1e-9, DT, k) == g0 + DT * RATE  # vapour: released


def test_the_gas_outlives_the_void_and_lags_the_rebound_force() -> None:
    """Cycles that boil at the stiffest click: with gas released, after the void collapses
    the chamber still holds gas, and the force moves where the floor alone has no effect
    (no void)."""
    f, fs = 1.5, 1000.0
    t = np.arange(int(2 * fs / f)) / fs
    w = 2 * np.pi * f
    x = 0.03 * np.sin(w * t)
    one = ModelInputs.single(x, 0.03 * w * np.cos(w * t), -w * w * x, 1 / fs)
    inputs = replace(one, periodic=True)  # whole cycles in their steady state
    bc, bt = (float(a) for a in SPEC.bleed_areas(0, 0))
    values = {"cavitation.release_pressure_pa": FLOOR}
    floor_only = DamperModel(SPEC, (make_term("cavitation"),), values)
    with_gas = DamperModel(
        SPEC, (make_term("cavitation"),), values | {"cavitation.gas_release_cm3_s": 3.0}
    )
    a = floor_only.evaluate(inputs, bc, bt)
    b = with_gas.evaluate(inputs, bc, bt)
    assert np.max(a.outputs["cavitation.vapour_m3"]) > 1e-8  # it boils: a void over 10 mm³
    gas = b.outputs["cavitation.gas_m3"]
    no_void = b.outputs["cavitation.vapour_m3"] == 0.0
    assert np.min(gas[no_void]) > 0.0  # the gas stays all cycle, long after the void
    # Where neither holds a void, the floor alone is the paper's chamber and the gas is a
    # compliance: the force there moves (the rebound chamber builds its pressure against it).
    calm = no_void & (a.outputs["cavitation.vapour_m3"] == 0.0)
    moved = b.force - a.force
    assert np.sqrt(np.mean(moved[calm] ** 2)) > 1.0


def _words(floor: float, release: float, sd: float, fixed: bool = False) -> str:
    from shockdyno.model.params import Estimate
    from shockdyno.model.reading import Reading

    term = make_term("cavitation")
    values = {p.name: Estimate(p.nominal, math.nan, p.unit, fixed=True) for p in term.params()}
    values["release_pressure_pa"] = Estimate(floor, 500.0, "Pa")
    values["gas_release_cm3_s"] = Estimate(release, sd, "cm³/s", fixed=fixed)
    return term.describe(Reading(term.PARAMS, values))


def test_the_released_gas_is_read_once_and_only_where_it_is_one() -> None:
    text = _words(82e3, 2.5, 0.3)
    assert "holds at 82 kPa absolute" in text, text
    assert "2.5 ± 0.3 cm³/s (at 1 atm)" in text and "over 5 s" in text, text
    # Within its noise of none: no gas is read (beside a floor that says nothing of it).
    assert "air comes out" not in _words(82e3, 0.2, 0.3), _words(82e3, 0.2, 0.3)
    assert "air comes out" not in _words(82e3, 0.0, math.nan, fixed=True)
    assert "2 cm³/s" in _words(82e3, 2.0, math.nan, fixed=True)  # given and held: as given
    # A floor below vacuum is no pressure a chamber holds: no gas is released at it, and
    # the text says none.
    below = _words(-20e3, 2.5, 0.3)
    assert "below vacuum" in below and "air comes out" not in below, below
