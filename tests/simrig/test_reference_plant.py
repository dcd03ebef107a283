"""The reference plant: its own physics (no term-library code), checked against closed
forms and against the paper's damper it should resemble when clean; and a real sim-rig
sweep that runs on it."""

from __future__ import annotations

import ast
import itertools
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shockdyno.errors import ConfigError
from shockdyno.model import DamperModel, ModelInputs, load_spec
from shockdyno.record import open_recording
from shockdyno.simrig import reference_kernel as kern
from shockdyno.simrig.reference import (
    P_ATM,
    PlantParams,
    ReferencePlant,
    needle_area,
    reference_sweep,
)
from shockdyno.simrig.scenario import load_scenario

REPO = Path(__file__).resolve().parents[2]
SPEC = load_spec()
FS = 1000.0


def _sine(f: float, cycles: float, amp: float = 0.03, mid: float = 0.0):
    t = np.arange(1, round(cycles / f * FS) + 1) / FS
    w = 2 * math.pi * f
    return t, mid + amp * np.sin(w * t), amp * w * np.cos(w * t), -amp * w * w * np.sin(w * t)


def _run(params: PlantParams, click: int, t, x, v, a, plant: ReferencePlant | None = None):
    """The plant's rows (reference_kernel.advance) and its final state, from rest at x[0]."""
    plant = plant or ReferencePlant(SPEC, params, FS)
    state = plant.initial(float(x[0]), 40.0)
    return plant.run_detail(t, x, v, a, (click, 0), state, 40.0)


def test_the_plant_imports_nothing_of_the_model_it_tests() -> None:
    ours: set[str] = set()
    for name in ("reference.py", "reference_kernel.py"):
        src = (REPO / "src/shockdyno/simrig" / name).read_text()
        for node in ast.walk(ast.parse(src)):
            if isinstance(node, ast.ImportFrom) and node.module:
                ours.add(node.module)
            elif isinstance(node, ast.Import):
                ours.update(a.name for a in node.names)
    ours = {m for m in ours if m.startswith("shockdyno")}
    allowed = {
        "shockdyno.errors",
        "shockdyno.schema",
        "shockdyno.model.spec",
        "shockdyno.record.types",
        "shockdyno.simrig",
    }
    assert ours <= allowed, ours
    # ...and uses none of the spec's derived laws, only its numbers
    laws = {"bleed_areas", "area", "stiffness_n_per_m", "preload_n", "crack_pressure_pa"}
    laws |= {"perimeter_m", "bleed_laminar_pa_s_m", "leak_conductance_m3_s_pa"}
    tree = ast.parse((REPO / "src/shockdyno/simrig/reference.py").read_text())
    used = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
    assert not used & laws, used & laws


def test_at_rest_the_plant_pushes_its_gas_force() -> None:
    z = np.zeros(200)
    t = (np.arange(200) + 1) / FS
    out, _ = _run(PlantParams(), 10, t, z, z, z)
    assert out[0, -1] == pytest.approx((SPEC.gas_pressure_pa - P_ATM) * SPEC.rod_area_m2, abs=0.5)


def test_clean_it_resembles_the_papers_damper_without_being_it() -> None:
    t, x, v, a = _sine(1.0, 3)
    out, _ = _run(PlantParams(), 10, t, x, v, a)
    areas = SPEC.bleed_areas(10, 0)
    paper = DamperModel(SPEC).force(ModelInputs.single(x, v, a, 1 / FS), *areas)
    keep = slice(1000, None)  # after the first cycle
    mine, theirs = out[0][keep], paper[keep]
    # the same damper within a fifth at its peaks, and not the same code
    assert np.ptp(mine) == pytest.approx(np.ptp(theirs), rel=0.2)
    assert max(mine) == pytest.approx(max(theirs), rel=0.35)
    assert min(mine) == pytest.approx(min(theirs), rel=0.2)
    assert float(np.sqrt(np.mean((mine - theirs) ** 2))) > 10.0


@pytest.mark.parametrize("speed", [0.02, -0.02])
def test_a_slow_steady_stroke_drops_the_orifice_law(speed: float) -> None:
    """Rigid oil, clean, click 20, a steady 20 mm/s: every bit of the swept annulus passes
    the open needle, whose flow number is far past its laminar range, so Δp is the sharp
    orifice's, ρ/2 (A_a v / (C_d∞ A))², and the plant's own passage law exactly."""
    params = PlantParams()
    plant = ReferencePlant(SPEC, params, FS)
    n = 1200
    t = np.arange(1, n + 1) / FS
    ramp = np.clip(t / 0.2, 0, 1)
    v = speed * (ramp - np.sin(2 * math.pi * ramp) / (2 * math.pi))
    x = -math.copysign(0.012, speed) + np.cumsum(v) / FS
    a = np.gradient(v, 1 / FS)
    _, state = _run(params, 20, t, x, v, a, plant)
    dp = state.s[kern.PK] - state.s[kern.PR]
    f = plant.paths(20, 0, 40.0)
    area = f[kern.F_AC] if speed > 0 else f[kern.F_AR]
    a_a = SPEC.annulus_area_m2
    q = a_a * abs(speed)
    rho = SPEC.oil_density_kg_m3
    cd = params.discharge_coefficient
    assert abs(dp) == pytest.approx(rho / 2 * (q / (cd * area)) ** 2, rel=0.03)
    gap = f[kern.F_GC] if speed > 0 else f[kern.F_GR]
    own = kern.passage(abs(dp), area, gap, params.needle_land_m, plant.k, plant.k[kern.MU40])
    leak = plant.k[kern.LEAK_G] / plant.k[kern.MU40] * abs(dp)
    assert own + leak == pytest.approx(q, rel=2e-3)
    assert math.copysign(1, dp) == math.copysign(1, speed)


def test_the_needle_opens_as_a_cone_in_its_seat_and_never_past_the_bore() -> None:
    seat = math.sqrt(4 * SPEC.compression_bleed.area_open_m2 / math.pi)
    areas = [needle_area(n, seat, 45.0) for n in range(22)]
    assert areas[0] == 0.0
    assert all(b > a for a, b in itertools.pairwise(areas))
    assert areas[-1] < math.pi / 4 * seat**2
    # a little lift: the cone's annulus, π h sin α d
    h = 0.5e-3 / 4
    assert needle_area(1, seat, 45.0) == pytest.approx(
        math.pi * h * math.sin(math.pi / 4) * seat, rel=0.05
    )


def test_a_bump_rubber_loop_holds_its_maxwell_branchs_loss() -> None:
    """Rod held in the rubber (onset 21 mm, 22-28 mm), 2 Hz: the bump's own force (the
    same run without it subtracted) loops with the standard linear solid's loss,
    π k_m δ_a² ωτ / (1 + (ωτ)²); its backbone is elastic and adds none."""
    f, amp, mid = 2.0, 0.003, 0.025
    t, x, v, a = _sine(f, 3, amp, mid)
    bump = PlantParams(bump_onset_m=0.021, bump_force_at_10mm_n=200.0)
    with_bump, _ = _run(bump, 10, t, x, v, a)
    without, _ = _run(PlantParams(), 10, t, x, v, a)
    fb = with_bump[0] - without[0]
    assert fb.min() > 0  # the rubber stays loaded
    one = slice(round(FS / f), round(2 * FS / f) + 1)  # the second cycle
    area = abs(float(np.trapezoid(fb[one], x[one])))
    k_m = bump.bump_loss_share * bump.bump_force_at_10mm_n / 0.010
    wt = 2 * math.pi * f * bump.bump_relaxation_time_s
    assert area == pytest.approx(math.pi * k_m * amp**2 * wt / (1 + wt * wt), rel=0.03)


def test_the_force_channel_lags_by_its_skew_and_the_load_cells_delay() -> None:
    """At 1 Hz each filter delays by its low-frequency group delay: the Bessel anti-alias
    (its a1/a0) on both channels, the load cell's 2ζ/ω_n and the skew on the force alone."""
    from scipy.signal import bessel

    skew = 0.003
    params = PlantParams(force_skew_s=skew)
    f = 1.0
    t, x, v, a = _sine(f, 3)
    out, _ = _run(params, 10, t, x, v, a)
    keep = slice(1000, 3000)
    w = 2 * math.pi * f
    basis = np.exp(-1j * w * t[keep])

    def phase(sig: np.ndarray) -> complex:
        return complex(np.sum(sig[keep] * basis))

    def delay(late: np.ndarray, early: np.ndarray) -> float:
        return float(np.angle(phase(early) / phase(late))) / w

    _, den = bessel(4, 2 * math.pi * params.anti_alias_hz, norm="mag", analog=True)
    bessel_s = den[-2] / den[-1]
    cell_s = 2 * params.load_cell_damping / (2 * math.pi * params.load_cell_hz)
    assert delay(out[2], x) == pytest.approx(bessel_s, rel=0.03)
    assert delay(out[1], out[0]) == pytest.approx(bessel_s + cell_s + skew, rel=0.01)
    assert delay(out[1], out[0]) - delay(out[2], x) == pytest.approx(skew + cell_s, rel=0.01)


def test_cavities_form_only_below_the_release_pressure() -> None:
    k = ReferencePlant(SPEC, PlantParams(), FS).k
    p_v = k[kern.P_V]
    assert kern.cavity_after(0.0, p_v + 1.0, k) == 0.0
    assert kern.cavity_after(0.0, p_v - 1e3, k) > 0.0
    assert 0.0 < kern.cavity_after(1e-7, p_v + 1e3, k) < 1e-7  # collapses above it
    assert kern.cavity_after(1e-7, p_v - 1e3, k) > 1e-7
    # A whole plant: at the spec's charge the rebound chamber never gets there and no
    # cavity forms; at 0.3 of it cavities form, and the chamber is held near p_v
    # (Rayleigh's growth needs a little under-pressure), never far below.
    _, spec_charge = reference_sweep(SPEC, PlantParams(), [2], (1.5,), cycles=2, seed=1)
    _, low = reference_sweep(SPEC, PlantParams(gas_pressure_factor=0.3), [2], (1.5,), cycles=2)
    assert spec_charge.max_vapour_m3 == 0.0 and spec_charge.lowest_rebound_pa > 1e5
    assert low.max_vapour_m3 > 1e-8
    assert p_v - 30e3 < low.lowest_rebound_pa < p_v


def test_the_seal_slides_at_its_hess_soom_level_after_an_elastic_turn() -> None:
    """A slow steady stroke (v ≪ v_s): the seal adds F_b / (1 + (v/v_s)²) to the Coulomb
    level; after reversal its force first grows with the travel at σ₀ = F_c/δ."""
    speed, fb = 0.0005, 40.0
    n = 3000
    t = np.arange(1, n + 1) / FS
    ramp = np.clip(t / 0.2, 0, 1)
    v = speed * (ramp - np.sin(2 * math.pi * ramp) / (2 * math.pi))
    x = np.cumsum(v) / FS
    a = np.gradient(v, 1 / FS)
    seal = PlantParams(breakaway_n=fb)
    with_fb, _ = _run(seal, 10, t, x, v, a)
    plain, _ = _run(PlantParams(), 10, t, x, v, a)
    level = fb / (1 + (speed / seal.stribeck_velocity_m_s) ** 2)
    assert with_fb[0][-1] - plain[0][-1] == pytest.approx(level, rel=0.01)
    # the first 2 µm of travel from rest: elastic, F_c/δ per metre
    early = np.searchsorted(x, 2e-6)
    slope = (plain[0][early] - plain[0][0]) / x[early]
    assert slope == pytest.approx(SPEC.friction_n / PlantParams().seal_presliding_m, rel=0.1)


def test_its_oil_and_air_have_the_modulus_of_their_own_laws() -> None:
    """Tait's tangent modulus rises by 1/C a pascal; free air at α by volume adds α/(κ p)."""
    k0, alpha = 1.6e9, 0.01
    plant = ReferencePlant(SPEC, PlantParams(oil_bulk_modulus_pa=k0, air_fraction=alpha), FS)
    p0 = SPEC.gas_pressure_pa
    liquid = k0 + (p0 - P_ATM) / kern.TAIT_C
    want = 1 / ((1 - alpha) / liquid + alpha / p0)
    assert plant.bulk_modulus_pa(p0) == pytest.approx(want, rel=0.01)
    oil = ReferencePlant(SPEC, PlantParams(oil_bulk_modulus_pa=k0), FS)
    assert oil.bulk_modulus_pa(P_ATM) == pytest.approx(k0, rel=1e-3)


def test_walther_viscosity_goes_through_both_points() -> None:
    plant = ReferencePlant(SPEC, PlantParams(viscosity_at_100c_cst=3.0), FS)
    rho = SPEC.oil_density_kg_m3
    assert plant.viscosity_pa_s(40.0) == pytest.approx(SPEC.oil_viscosity_cst * 1e-6 * rho)
    assert plant.viscosity_pa_s(100.0) == pytest.approx(3.0e-6 * rho)
    held = ReferencePlant(SPEC, PlantParams(), FS)
    assert held.viscosity_pa_s(80.0) == held.viscosity_pa_s(40.0)
    with pytest.raises(ConfigError, match="viscosity_at_100c_cst"):
        ReferencePlant(SPEC, PlantParams(viscosity_at_100c_cst=20.0), FS)


@pytest.mark.parametrize("oil_pa", [1.6e9, 4.0e8])
def test_compressible_oil_is_neither_made_nor_lost_through_the_piston(oil_pa: float) -> None:
    """Whole cycles from rest at mid-stroke back to rest there: the oil's mass is what
    it was, so the gas piston is back where it started (the rod's volume is back out)."""
    f, cycles = 1.5, 3
    w = 2 * math.pi * f
    t = np.arange(1, round(cycles / f * FS) + 1) / FS
    # From rest and back: x = A (1 - cos ωt), its velocity and acceleration exact.
    x, v, a = 0.015 * (1 - np.cos(w * t)), 0.015 * w * np.sin(w * t), 0.015 * w * w * np.cos(w * t)
    plant = ReferencePlant(SPEC, PlantParams(oil_bulk_modulus_pa=oil_pa, air_fraction=0.01), FS)
    state = plant.initial(0.0, 40.0)
    mass = state.s[kern.MR] + state.s[kern.MK]
    *_, state = plant.run(t, x, v, a, (10, 0), state, 40.0)
    rest = np.zeros(2000)
    *_, state = plant.run(
        t[-1] + (np.arange(2000) + 1) / FS, rest, rest, rest, (10, 0), state, 40.0
    )
    assert state.s[kern.MR] + state.s[kern.MK] == pytest.approx(mass, rel=1e-12)
    assert abs(state.s[kern.YG]) * 1e6 < 1.0, state.s[kern.YG]
    assert state.s[kern.PR] == pytest.approx(SPEC.gas_pressure_pa, rel=1e-3)


def test_a_scenario_selects_the_plant_and_says_what_is_wrong(tmp_path: Path) -> None:
    good = tmp_path / "ref.toml"
    good.write_text('[scenario]\nname = "r"\n[plant]\nkind = "reference"\nair_fraction = 0.01\n')
    sc = load_scenario(good)
    assert sc.plant is not None and sc.plant.air_fraction == 0.01
    bad = tmp_path / "bad.toml"
    bad.write_text('[scenario]\nname = "r"\n[plant]\nkind = "reference"\nair = 0.01\n')
    with pytest.raises(ConfigError, match=r"bad.toml: plant.air: unknown key"):
        load_scenario(bad)
    both = tmp_path / "both.toml"
    both.write_text(
        '[scenario]\nname = "r"\n[plant]\nkind = "reference"\n[[term]]\nkind = "friction"\n'
    )
    with pytest.raises(ConfigError, match="not terms"):
        load_scenario(both)


def test_an_offline_reference_sweep_keeps_whole_cycles_and_its_heat() -> None:
    tests, truth = reference_sweep(SPEC, PlantParams(), [10], (1.5,), cycles=2, seed=3)
    (only,) = tests
    assert only.t.size == round(2 / 1.5 * FS) + 1
    assert only.x[0] == pytest.approx(-0.03, abs=2e-4)  # from the bottom of the stroke
    assert truth.oil_temperature_c[1] > 40.0  # the damper warmed as it worked
    assert only.temperature is not None and only.temperature[-1] > only.temperature[0]


def test_clicks_outside_the_adjusters_range_are_refused() -> None:
    plant = ReferencePlant(SPEC, PlantParams(), FS)
    with pytest.raises(ConfigError, match="rod clicks must be 0-21"):
        plant.paths(22, 0, 40.0)


# A fresh-clone run (2 cores, the concealed-effect diagnoses on the other worker) passed
# pytest's 120 s with an earlier plant's sweep unfinished: the sweep's own 240 s bound
# decides, and on a timeout its output is shown, so the next such run says where it was.
@pytest.mark.timeout(300)
def test_a_real_sweep_runs_on_the_reference_plant(tmp_path: Path) -> None:
    sc = tmp_path / "ref.toml"
    sc.write_text('[scenario]\nname = "r"\n[plant]\nkind = "reference"\nbreakaway_n = 40\n')
    out = tmp_path / "ref.mcap"
    # An earlier plant's stiff solver could hold a step for over a second on a shared
    # core; this test is the plant running a real sweep (the frozen-DAQ stop and the
    # Modbus timeout have their own tests), so its rig file waits 5 s for a frame and
    # 10 s for a Modbus answer.
    rig = tmp_path / "sim.toml"
    text = (REPO / "rigs/sim.toml").read_text()
    assert "frozen_timeout_s = 1.0 " in text and "\ntimeout_s = 0.5 " in text
    text = text.replace("frozen_timeout_s = 1.0 ", "frozen_timeout_s = 5.0 ")
    rig.write_text(text.replace("\ntimeout_s = 0.5 ", "\ntimeout_s = 10.0 "))
    cli = [sys.executable, "-m", "shockdyno.cli", "sweep", "--rig", str(rig)]
    cli += ["--start-sim", "--speed", "0.5", "--clicks", "10", "--freq", "1.5", "--cycles", "2"]
    cli += ["--warmup-cycles", "1", "--scenario", str(sc), "-o", str(out), "--seed", "4"]
    try:
        done = subprocess.run(
            cli, capture_output=True, text=True, timeout=240, env={**os.environ, "COLUMNS": "200"}
        )
    except subprocess.TimeoutExpired as exc:
        got = (exc.stdout or b"")[-1500:], (exc.stderr or b"")[-1500:]
        pytest.fail(f"the sweep ran past 240 s; stdout ...{got[0]!r}; stderr ...{got[1]!r}")
    assert done.returncode == 0, done.stderr[-400:]
    (test,) = open_recording(out).load_all()
    assert test.meta.clicks == 10 and np.ptp(test.x) == pytest.approx(0.06, rel=0.05)
    assert 500 < float(np.max(test.force)) < 2000
