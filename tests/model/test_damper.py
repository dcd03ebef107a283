"""The damper model against answers known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shockdyno.model import damper_force, differentiate, evaluate, load_spec, talbott_force
from shockdyno.model.damper import ATMOSPHERE_PA, force_from_displacement
from shockdyno.model.gas import gas_pressure

SPEC = load_spec()


def _shut_valves_and_leak():
    """The default damper with both shim stacks that never open and no piston-wall gap."""
    comp = SPEC.compression_valve
    reb = SPEC.rebound_valve
    from dataclasses import replace

    return SPEC.with_changes(
        compression_valve=replace(comp, max_lift_m=0.0),
        rebound_valve=replace(reb, max_lift_m=0.0),
        leak_gap_m=0.0,
    )


def test_gas_force_alone_is_eq5_times_rod_area():
    x = np.linspace(-0.03, 0.03, 13)
    zero = np.zeros_like(x)
    f = damper_force(SPEC, x, zero, zero, 5e-6, 3e-6)
    v0 = SPEC.gas_piston_area_m2 * SPEC.gas_length_m
    p_g = SPEC.gas_pressure_pa * v0 / (v0 - SPEC.rod_area_m2 * x)  # eq. 5 written out again
    np.testing.assert_allclose(f, (p_g - ATMOSPHERE_PA) * SPEC.rod_area_m2, rtol=1e-12)
    # Compressing the gas stiffens the damper: more force at +30 mm than at -30 mm.
    assert f[-1] > f[0] > 0


def test_bleed_only_force_matches_orifice_formula():
    spec = _shut_valves_and_leak()
    v = np.concatenate([np.linspace(-0.3, -0.01, 30), np.linspace(0.01, 0.3, 30)])
    zero = np.zeros_like(v)
    a_bc, a_bt = 7e-6, 2e-6
    f = damper_force(spec, zero, v, zero, a_bc, a_bt)
    q = spec.annulus_area_m2 * v
    area = np.where(v > 0, a_bc, a_bt)
    dp = spec.oil_density_kg_m3 / 2 * (q / (spec.discharge_coefficient * area)) ** 2 * np.sign(v)
    gas = (spec.gas_pressure_pa - ATMOSPHERE_PA) * spec.rod_area_m2
    friction = spec.friction_n * np.tanh(v / spec.friction_velocity_m_s)
    np.testing.assert_allclose(f, gas + dp * spec.annulus_area_m2 + friction, rtol=1e-9)


@pytest.mark.parametrize("clicks", [0, 1, 3, 7, 12, 21])
def test_force_is_monotone_in_velocity_within_each_stroke(clicks):
    a_bc, a_bt = SPEC.bleed_areas(clicks)
    for v in (np.linspace(1e-4, 0.6, 3000), np.linspace(-0.6, -1e-4, 3000)):
        zero = np.zeros_like(v)
        f = damper_force(SPEC, zero, v, zero, a_bc, a_bt)
        assert np.all(np.diff(f) > 0), f"force not increasing with velocity at {clicks} clicks"


@pytest.mark.parametrize("freq", [0.5, 1.0, 1.5])
def test_energy_dissipated_per_cycle_is_positive(freq):
    t = np.arange(0, 1 / freq, 1e-4)
    w = 2 * math.pi * freq
    x = 0.03 * np.sin(w * t)
    v = 0.03 * w * np.cos(w * t)
    a = -(w**2) * x
    for clicks in (0, 10, 21):
        a_bc, a_bt = SPEC.bleed_areas(clicks)
        f = damper_force(SPEC, x, v, a, a_bc, a_bt)
        work = np.trapezoid(f * v, t)  # energy the dyno puts in over one closed cycle
        assert work > 0
        # Gas and inertia are conservative: the work equals that of the dissipative parts.
        bd = evaluate(SPEC, x, v, a, a_bc, a_bt)
        dissipative = np.trapezoid((bd.f_hydraulic + bd.f_friction) * v, t)
        assert work == pytest.approx(dissipative, rel=1e-3)


def test_proposed_equals_talbott_when_areas_are_equal_and_splits_by_stroke_otherwise():
    t = np.arange(0, 2, 1e-3)
    x = 0.03 * np.sin(2 * math.pi * t)
    v, a = differentiate(t, x)
    np.testing.assert_array_equal(
        damper_force(SPEC, x, v, a, 6e-6, 6e-6), talbott_force(SPEC, x, v, a, 6e-6)
    )
    proposed = damper_force(SPEC, x, v, a, 8e-6, 2e-6)
    comp, reb = v > 0, v < 0
    np.testing.assert_allclose(proposed[comp], talbott_force(SPEC, x, v, a, 8e-6)[comp])
    np.testing.assert_allclose(proposed[reb], talbott_force(SPEC, x, v, a, 2e-6)[reb])
    assert not np.allclose(proposed, talbott_force(SPEC, x, v, a, 5e-6))


def test_bleed_area_is_monotone_in_clicks_and_closed_at_zero():
    clicks = np.arange(0, 22)
    a_bc, a_bt = SPEC.bleed_areas(clicks)
    assert a_bc[0] == 0 and a_bt[0] == 0
    assert np.all(np.diff(a_bc) > 0) and np.all(np.diff(a_bt) > 0)
    # The gas-bottle selector opens the rebound path only.
    bc_g, bt_g = SPEC.bleed_areas(10, 5)
    assert bc_g == a_bc[10] and bt_g > a_bt[10]
    # Compression saturates (paper Fig. 12a): the last clicks change little.
    assert (a_bc[21] - a_bc[15]) < 0.2 * (a_bc[6] - a_bc[0])


def test_forces_are_of_racing_damper_order():
    """Hundreds to a few thousand newtons at 0.05-0.3 m/s, stiffer with fewer clicks."""
    v = np.array([-0.3, -0.1, -0.05, 0.05, 0.1, 0.3])
    zero = np.zeros_like(v)
    stiff = damper_force(SPEC, zero, v, zero, *SPEC.bleed_areas(2))
    soft = damper_force(SPEC, zero, v, zero, *SPEC.bleed_areas(21))
    assert np.all((np.abs(stiff) > 200) & (np.abs(stiff) < 5000))
    assert 500 < abs(stiff[0]) < 5000 and 500 < stiff[-1] < 5000
    assert np.all(np.abs(stiff[[0, 1, 4, 5]]) > np.abs(soft[[0, 1, 4, 5]]))


def test_noise_on_displacement_does_not_blow_up_the_force():
    rng = np.random.default_rng(1)
    t = np.arange(0, 4, 1e-3)
    w = 2 * math.pi * 1.5
    x = 0.03 * np.sin(w * t)
    a_bc, a_bt = SPEC.bleed_areas(6)
    exact = damper_force(SPEC, x, 0.03 * w * np.cos(w * t), -(w**2) * x, a_bc, a_bt)
    noisy = x + rng.normal(0, 5e-6, x.size)  # 5 µm LVDT noise
    robust = force_from_displacement(SPEC, t, noisy, a_bc, a_bt)
    v_fd = np.gradient(noisy, t)
    naive = damper_force(SPEC, noisy, v_fd, np.gradient(v_fd, t), a_bc, a_bt)
    inner = slice(50, -50)
    err_robust = np.sqrt(np.mean((robust - exact)[inner] ** 2))
    err_naive = np.sqrt(np.mean((naive - exact)[inner] ** 2))
    assert err_robust < 0.01 * np.std(exact)
    assert err_naive > 5 * err_robust


def test_gas_pressure_rises_as_rod_enters():
    assert gas_pressure(SPEC, np.array([0.0]))[0] == pytest.approx(SPEC.gas_pressure_pa)
    assert gas_pressure(SPEC, np.array([0.03]))[0] > SPEC.gas_pressure_pa
