"""Scenario physics terms (model/extras.py) against analytic answers, and scenario files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from shockdyno.errors import ConfigError
from shockdyno.model import damper_force, evaluate, load_spec
from shockdyno.model.damper import ATMOSPHERE_PA
from shockdyno.model.extras import (
    Cavitation,
    Compressibility,
    LoadCellLag,
    SealFriction,
    ThermalViscosity,
    make_term,
)
from shockdyno.simrig.scenario import load_scenario

REPO = Path(__file__).resolve().parents[2]
SPEC = load_spec()
A_BC, A_BT = SPEC.bleed_areas(8, 0)


def test_cavitation_clamps_the_rebound_chamber_at_vapour_pressure() -> None:
    v = np.linspace(0.05, 4.0, 80)  # ever faster compression: p_r = p_c - Δp falls
    x = np.zeros_like(v)
    a = np.zeros_like(v)
    plain = evaluate(SPEC, x, v, a, A_BC, A_BT)
    cav = Cavitation(vapour_pressure_pa=3000.0)
    br = evaluate(SPEC, x, v, a, A_BC, A_BT, terms=[cav])
    assert np.min(plain.p_r) < 3000.0  # the plain model goes below vapour pressure
    assert np.all(br.p_r >= 3000.0 - 1e-9)
    limit = (br.p_c - 3000.0) * SPEC.annulus_area_m2
    assert np.all(br.f_hydraulic <= limit + 1e-6)
    assert br.f_hydraulic[-1] == pytest.approx(limit[-1])  # saturated
    ok = plain.p_r > 3000.0
    assert np.allclose(br.force[ok], plain.force[ok])  # untouched where no cavitation


def test_seal_friction_breakaway_and_coulomb_levels() -> None:
    term = SealFriction(static_n=60, coulomb_n=35, stribeck_velocity_m_s=0.005, viscous_n_s_m=40)
    v = np.array([0.003, 0.5, -0.5])  # 3 mm/s: past the smoothing, inside Stribeck
    x = np.zeros(3)
    with_term = evaluate(SPEC, x, v, x, A_BC, A_BT, terms=[term]).f_friction
    expected0 = (35 + 25 * math.exp(-((0.003 / 0.005) ** 2))) * math.tanh(
        0.003 / 0.0005
    ) + 40 * 0.003
    assert with_term[0] == pytest.approx(expected0)
    assert with_term[1] == pytest.approx(35 + 40 * 0.5, rel=1e-6)
    assert with_term[2] == pytest.approx(-(35 + 40 * 0.5), rel=1e-6)


def test_compressibility_lags_the_pressure_by_its_time_constant() -> None:
    term = Compressibility(sample_rate_hz=1000.0)
    tau = term.time_constant_s(SPEC.gas_pressure_pa)
    beta = 1 / (0.98 / 1.5e9 + 0.02 / SPEC.gas_pressure_pa)
    assert tau == pytest.approx(1e-4 / (beta * 2e-11))
    n = 1000
    t = np.arange(n) / 1000.0
    v = np.where(t > 0.1, 0.2, 0.0)  # a velocity step at 0.1 s
    x = np.zeros(n)
    static = evaluate(SPEC, x, v, x, A_BC, A_BT, t=t).dp
    lagged = evaluate(SPEC, x, v, x, A_BC, A_BT, terms=[term], t=t).dp
    k = 100 + round(tau * 1000)  # one time constant after the step
    assert lagged[k] / static[k] == pytest.approx(1 - math.exp(-1), abs=0.02)


def test_stateful_terms_give_the_same_answer_split_or_whole() -> None:
    t = np.arange(2000) / 1000.0
    x = 0.03 * np.sin(2 * np.pi * 1.5 * t)
    v = 0.03 * 2 * np.pi * 1.5 * np.cos(2 * np.pi * 1.5 * t)
    a = -((2 * np.pi * 1.5) ** 2) * x
    for make in (Compressibility, ThermalViscosity, LoadCellLag):
        whole = damper_force(SPEC, x, v, a, A_BC, A_BT, terms=[make()], t=t)
        term = make()
        parts = [
            damper_force(SPEC, x[s], v[s], a[s], A_BC, A_BT, terms=[term], t=t[s])
            for s in (slice(0, 700), slice(700, 710), slice(710, 2000))
        ]
        assert np.array_equal(whole, np.concatenate(parts)), make.__name__


def test_thermal_steady_state_and_gas_force() -> None:
    term = ThermalViscosity(heat_capacity_j_k=10.0, cooling_w_k=2.0, dissipation_n_s_m=1000.0)
    n = 60_000  # 60 s ≫ C/h = 5 s
    v = np.full(n, 0.2)
    t = np.arange(n) / 1000.0
    x = np.zeros(n)
    br = evaluate(SPEC, x, v, x, A_BC, A_BT, terms=[term], t=t)
    rise = 1000.0 * 0.2**2 / 2.0  # c v² / h = 20 K
    assert term.temperature_c[-1] == pytest.approx(40.0 + rise, rel=1e-3)
    ratio = (60.0 + 273.15) / (40.0 + 273.15)
    plain = evaluate(SPEC, x[:1], v[:1], x[:1], A_BC, A_BT)
    assert br.f_gas[-1] + ATMOSPHERE_PA * SPEC.rod_area_m2 == pytest.approx(
        plain.p_c[0] * ratio * SPEC.rod_area_m2, rel=1e-3
    )


def test_load_cell_lag_passes_a_constant_force_and_delays_a_step() -> None:
    term = LoadCellLag(time_constant_s=0.002)
    n = 100
    t = np.arange(n) / 1000.0
    v = np.where(t >= 0.05, 0.1, 0.0)
    x = np.zeros(n)
    plain = damper_force(SPEC, x, v, x, A_BC, A_BT, t=t)
    lagged = damper_force(SPEC, x, v, x, A_BC, A_BT, terms=[term], t=t)
    assert lagged[10] == pytest.approx(plain[10])
    k = 50 + 2  # one time constant after the step
    frac = (lagged[k] - plain[0]) / (plain[k] - plain[0])
    assert frac == pytest.approx(1 - math.exp(-1.5), abs=0.03)  # 3 samples into the lag


@pytest.mark.parametrize("path", sorted((REPO / "sim" / "scenarios").glob("*.toml")), ids=str)
def test_every_scenario_file_loads(path: Path) -> None:
    sc = load_scenario(path)
    assert sc.terms and sc.description
    assert load_scenario(path.stem).name == sc.name  # by name from sim/scenarios/


def test_scenario_mistakes_are_config_errors() -> None:
    with pytest.raises(ConfigError, match="unknown kind 'magic'"):
        make_term("magic", {})
    with pytest.raises(ConfigError, match="unknown key 'bulk' for compressibility"):
        make_term("compressibility", {"bulk": 1.0})
    with pytest.raises(ConfigError, match="scenario not found: nope"):
        load_scenario("nope")
