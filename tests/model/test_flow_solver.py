"""The vectorised pressure-drop solve passes exactly the flow asked of it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shockdyno.model import load_spec
from shockdyno.model.flow import passed_flow, solve_pressure_drop, solve_signed_drop

SPEC = load_spec()
CD, RHO = SPEC.discharge_coefficient, SPEC.oil_density_kg_m3

# The operating range: rod speeds to 2 m/s on a 40 mm piston, bleed from shut to the full
# 9 mm bore, leak conductance from none to a worn piston, both valves.
flows = st.floats(0.0, 2.0 * SPEC.annulus_area_m2)
areas = st.floats(0.0, 6.3e-5)
leaks = st.sampled_from([0.0, SPEC.leak_conductance_m3_s_pa, 1e-10])
valves = st.sampled_from([SPEC.compression_valve, SPEC.rebound_valve])


@settings(max_examples=300, deadline=None)
@given(q=st.lists(flows, min_size=1, max_size=50), a_b=areas, k=leaks, valve=valves)
def test_solved_pressure_drop_passes_the_requested_flow(q, a_b, k, valve):
    q_arr = np.array(q)
    dp = solve_pressure_drop(q_arr, a_b, valve, CD, RHO, k)
    assert np.all(dp >= 0)
    np.testing.assert_allclose(
        passed_flow(dp, a_b, valve, CD, RHO, k), q_arr, rtol=1e-8, atol=1e-15
    )


@settings(max_examples=100, deadline=None)
@given(q=flows, preload=st.floats(0.0, 1e-3), lift=st.floats(0.0, 1e-3))
def test_solve_handles_valves_from_shut_to_wide_open(q, preload, lift):
    valve = replace(SPEC.compression_valve, preload_m=preload, max_lift_m=lift)
    dp = solve_pressure_drop(np.array([q]), 0.0, valve, CD, RHO, SPEC.leak_conductance_m3_s_pa)
    np.testing.assert_allclose(
        passed_flow(dp, 0.0, valve, CD, RHO, SPEC.leak_conductance_m3_s_pa),
        q,
        rtol=1e-8,
        atol=1e-15,
    )


def test_zero_flow_needs_zero_pressure():
    dp = solve_pressure_drop(np.zeros(5), 1e-6, SPEC.compression_valve, CD, RHO, 0.0)
    assert np.all(dp == 0)


def test_pressure_drop_is_monotone_in_flow():
    q = np.linspace(0, 1e-3, 2000)
    dp = solve_pressure_drop(q, 3e-6, SPEC.rebound_valve, CD, RHO, SPEC.leak_conductance_m3_s_pa)
    assert np.all(np.diff(dp) > 0)


def test_solve_agrees_with_brentq_on_the_equations_written_out_again():
    """An independent scalar root-find of eq. 3, 4 and 7 with the valve law spelt out."""
    from scipy.optimize import brentq

    k_leak = SPEC.leak_conductance_m3_s_pa
    for valve in (SPEC.compression_valve, SPEC.rebound_valve):
        k = valve.stiffness_n_per_m
        for a_b in (0.0, 1e-6, 8e-6):
            for q in (1e-6, 3e-5, 1e-4, 3e-4):

                def residual(dp, a_b=a_b, q=q, valve=valve, k=k):  # type: ignore[no-untyped-def]
                    lift = min(max((dp * valve.face_area_m2 - k * valve.preload_m) / k, 0.0),
                               valve.max_lift_m)  # fmt: skip
                    area = a_b + np.pi * valve.seat_diameter_m * lift
                    return CD * area * np.sqrt(2 * dp / RHO) + k_leak * dp - q

                expected = brentq(residual, 0.0, 1e10, xtol=1e-6, rtol=1e-13)
                got = solve_pressure_drop(np.array([q]), a_b, valve, CD, RHO, k_leak)[0]
                assert got == pytest.approx(expected, rel=1e-7)


@pytest.mark.parametrize("land", [0.0, 2.0e9])
def test_both_directions_in_one_pass_are_each_direction_apart(land: float) -> None:
    """The model's solve (`solve_signed_drop`: every sample through its own direction's
    bleed and valve, one pass) gives what each direction's samples solved apart give, to
    the solve's tolerance (each starts Newton from its neighbour's root, and the
    neighbours differ), and 0 where nothing flows."""
    rng = np.random.default_rng(4)
    n = 4000
    q = rng.normal(0.0, 2e-4, n)
    q[::50] = 0.0
    a_bc, a_bt = rng.uniform(0.0, 8e-6, n), rng.uniform(0.0, 8e-6, n)
    k = rng.uniform(0.0, 1e-12, n)
    lam = np.full(n, land)
    got = solve_signed_drop(
        q, a_bc, a_bt, SPEC.compression_valve, SPEC.rebound_valve, CD, RHO, k, lam
    )
    comp, reb = q > 0, q < 0
    want = np.zeros(n)
    want[comp] = solve_pressure_drop(
        q[comp], a_bc[comp], SPEC.compression_valve, CD, RHO, k[comp], lam[comp]
    )
    want[reb] = -solve_pressure_drop(
        q[reb], a_bt[reb], SPEC.rebound_valve, CD, RHO, k[reb], lam[reb]
    )
    assert np.all(got[q == 0.0] == 0.0)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=0.0)


def test_a_seat_land_is_a_plane_poiseuille_flow_in_series_with_the_opening():
    """A stack with a seat land λ_v = 12 μ L: at full lift y, Δp = (q/(c P y))² + λ_v q/(P y³)
    (written out here, with no bleed or leak), and below the crack nothing changes; the
    solve passes what `passed_flow` says it does, on both directions in one pass."""
    land = SPEC.with_values({"valve_land_m": 1.0e-3})
    lam_v = land.valve_laminar_pa_s
    assert lam_v == pytest.approx(12 * SPEC.viscosity_pa_s * 1.0e-3)
    c = CD * np.sqrt(2 / RHO)
    for valve in (SPEC.compression_valve, SPEC.rebound_valve):
        y, perim = valve.max_lift_m, valve.perimeter_m
        full = (valve.stiffness_n_per_m * y + valve.preload_n) / valve.face_area_m2
        q = np.array([3e-3, 5e-3, 8e-3])
        want = (q / (c * perim * y)) ** 2 + lam_v * q / (perim * y**3)
        assert np.all(want > full)  # at full lift
        got = solve_pressure_drop(q, 0.0, valve, CD, RHO, 0.0, 0.0, lam_v)
        np.testing.assert_allclose(got, want, rtol=1e-9)
        # with a bleed and the leak, wherever the stack is: the flow asked for
        q = np.linspace(1e-6, 6e-4, 200)
        k_leak = SPEC.leak_conductance_m3_s_pa
        dp = solve_pressure_drop(q, 3e-6, valve, CD, RHO, k_leak, 0.0, lam_v)
        np.testing.assert_allclose(
            passed_flow(dp, 3e-6, valve, CD, RHO, k_leak, 0.0, lam_v), q, rtol=1e-8
        )
        shut = dp < valve.preload_n / valve.face_area_m2
        assert 0 < np.count_nonzero(shut) < q.size
        np.testing.assert_allclose(
            dp[shut], solve_pressure_drop(q[shut], 3e-6, valve, CD, RHO, k_leak), rtol=1e-9
        )
        assert np.all(dp[~shut] > solve_pressure_drop(q[~shut], 3e-6, valve, CD, RHO, k_leak))
    n = 400
    qs = np.linspace(-6e-4, 6e-4, n)
    both = solve_signed_drop(
        qs, np.full(n, 3e-6), np.full(n, 2e-6), SPEC.compression_valve, SPEC.rebound_valve,
        CD, RHO, np.zeros(n), np.zeros(n), None, np.full(n, lam_v),
    )  # fmt: skip
    comp, reb = qs > 0, qs < 0
    np.testing.assert_allclose(
        both[comp],
        solve_pressure_drop(qs[comp], 3e-6, SPEC.compression_valve, CD, RHO, 0.0, 0.0, lam_v),
        rtol=1e-9,
    )
    np.testing.assert_allclose(
        -both[reb],
        solve_pressure_drop(qs[reb], 2e-6, SPEC.rebound_valve, CD, RHO, 0.0, 0.0, lam_v),
        rtol=1e-9,
    )
