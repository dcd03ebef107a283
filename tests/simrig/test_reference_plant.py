"""The reference plant: its own physics (no term-library code), checked against closed
forms and against the paper's damper it should resemble when clean; and a real sim-rig
sweep that runs on it."""

from __future__ import annotations

import ast
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
from shockdyno.simrig.reference import P_ATM, PlantParams, ReferencePlant, reference_sweep
from shockdyno.simrig.scenario import load_scenario

REPO = Path(__file__).resolve().parents[2]
SPEC = load_spec()
FS = 1000.0


def _run(params: PlantParams, click: int, f: float, cycles: float = 3.0):
    t = np.arange(0, cycles / f, 1 / FS) + 1 / FS
    w = 2 * math.pi * f
    x, v, a = 0.03 * np.sin(w * t), 0.03 * w * np.cos(w * t), -0.03 * w * w * np.sin(w * t)
    plant = ReferencePlant(SPEC, params, FS)
    state = plant.initial(0.0, 40.0)
    areas = tuple(float(q) for q in SPEC.bleed_areas(click, 0))
    force, sensed, _, _, state = plant.run(t, x, v, a, areas, state, 40.0)  # type: ignore[arg-type]
    return t, x, v, a, areas, force, sensed, state


def test_the_plant_imports_nothing_of_the_model_it_tests() -> None:
    src = (REPO / "src/shockdyno/simrig/reference.py").read_text()
    imported = set()
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module)
        elif isinstance(node, ast.Import):
            imported.update(a.name for a in node.names)
    ours = {m for m in imported if m.startswith("shockdyno")}
    allowed = {
        "shockdyno.errors",
        "shockdyno.schema",
        "shockdyno.model.spec",
        "shockdyno.record.types",
    }
    assert ours <= allowed, ours


def test_at_rest_the_plant_pushes_its_gas_force() -> None:
    plant = ReferencePlant(SPEC, PlantParams(), FS)
    state = plant.initial(0.0, 40.0)
    z = np.zeros(200)
    t = (np.arange(200) + 1) / FS
    force, *_ = plant.run(t, z, z, z, (1e-6, 1e-6), state, 40.0)
    assert force[-1] == pytest.approx((SPEC.gas_pressure_pa - P_ATM) * SPEC.rod_area_m2, abs=0.5)


def test_clean_it_resembles_the_papers_damper_without_being_it() -> None:
    _, x, v, a, areas, force, _, _ = _run(PlantParams(), 10, 1.0)
    paper = DamperModel(SPEC).force(ModelInputs.single(x, v, a, 1 / FS), *areas)
    keep = slice(1000, None)  # after the first cycle
    diff = force[keep] - paper[keep]
    rms = float(np.sqrt(np.mean(diff**2)))
    assert 1.0 < rms < 0.03 * float(np.max(np.abs(paper)))  # close, and not the same code


def test_a_low_charge_makes_vapour_and_the_spec_charge_does_not() -> None:
    _, spec_charge = reference_sweep(SPEC, PlantParams(), [2], (1.5,), cycles=2, seed=1)
    _, low = reference_sweep(SPEC, PlantParams(gas_pressure_factor=0.3), [2], (1.5,), cycles=2)
    assert spec_charge.max_vapour_m3 < 1e-9 and spec_charge.lowest_rebound_pa > 1e5
    assert low.max_vapour_m3 > 1e-8
    # The vapour state holds the chamber near its release pressure, never far below it.
    assert low.lowest_rebound_pa > PlantParams().release_pressure_pa - 5e3


@pytest.mark.parametrize("oil_pa", [1.6e9, 4.0e8])
def test_compressible_oil_is_neither_made_nor_lost_through_the_piston(oil_pa: float) -> None:
    """Whole cycles from rest at mid-stroke back to rest there: the oil's mass is what
    it was, so the gas piston is back where it started (the rod's volume is back out).
    A flow counted as one volume on both sides of the piston lost the dissipated power
    over β: the gas piston ended 61 µm (1.6 GPa) and 240 µm (0.4 GPa) off here."""
    f, cycles = 1.5, 3
    w = 2 * math.pi * f
    t = np.arange(1, round(cycles / f * FS) + 1) / FS
    # From rest and back: x = A (1 - cos ωt), its velocity and acceleration exact.
    x, v, a = 0.015 * (1 - np.cos(w * t)), 0.015 * w * np.sin(w * t), 0.015 * w * w * np.cos(w * t)
    plant = ReferencePlant(SPEC, PlantParams(oil_bulk_modulus_pa=oil_pa), FS)
    state = plant.initial(0.0, 40.0)
    areas = tuple(float(q) for q in SPEC.bleed_areas(10, 0))
    *_, state = plant.run(t, x, v, a, areas, state, 40.0)  # type: ignore[arg-type]
    rest = np.zeros(2000)
    *_, state = plant.run(t[-1] + (np.arange(2000) + 1) / FS, rest, rest, rest, areas, state, 40.0)  # type: ignore[arg-type]
    moved_um = float(state.y[2]) * 1e6
    assert abs(moved_um) < 1.0, moved_um
    assert state.y[0] == pytest.approx(SPEC.gas_pressure_pa, rel=1e-4)


def test_the_force_channel_is_skewed_by_its_stated_time() -> None:
    skew = 0.004
    _, _, _, _, _, force, sensed, _ = _run(
        PlantParams(force_skew_s=skew, anti_alias_hz=480), 10, 1.0
    )
    keep = slice(500, None)
    lags = np.arange(0, 10)
    err = [
        float(np.mean((sensed[keep][k:] - force[keep][: force[keep].size - k]) ** 2)) for k in lags
    ]
    # Best alignment at the skew plus the anti-alias filter's own small group delay.
    assert int(np.argmin(err)) in (4, 5)


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


# A fresh-clone run (2 cores, the concealed-effect diagnoses on the other worker) passed
# pytest's 120 s with this sweep unfinished, though it takes 18-23 s here alone or beside
# four busy loops (3.7 s of CPU): the sweep's own 240 s bound decides, and on a timeout
# its output is shown, so the next such run says where the sweep was.
@pytest.mark.timeout(300)
def test_a_real_sweep_runs_on_the_reference_plant(tmp_path: Path) -> None:
    sc = tmp_path / "ref.toml"
    sc.write_text('[scenario]\nname = "r"\n[plant]\nkind = "reference"\nbreakaway_n = 40\n')
    out = tmp_path / "ref.mcap"
    # The stiff solver can hold a 30-50-sample step for over a second on a shared core (a
    # fresh-clone run on an idle 2-core machine stopped on "DAQ frozen: no valid frame for
    # 1.00 s"); this test is the plant running a real sweep, the frozen-DAQ stop has its own
    # (tests/contract/test_contract_sim.py), so this rig file waits 5 s for a frame. A
    # command waits for the batch under way, and a batch where the first solver gives up
    # took 0.49 s on an idle machine (a loaded suite run timed out writing the clicks at
    # rigs/sim.toml's 0.5 s); the Modbus timeout has its own tests too, so 10 s here (3 s
    # was not enough for a fresh-clone run: the same write timed out, though no batch of
    # this sweep took over 0.36 s here beside four busy loops; the cause is not found).
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
        out = (exc.stdout or b"")[-1500:], (exc.stderr or b"")[-1500:]
        pytest.fail(f"the sweep ran past 240 s; stdout ...{out[0]!r}; stderr ...{out[1]!r}")
    assert done.returncode == 0, done.stderr[-400:]
    (test,) = open_recording(out).load_all()
    assert test.meta.clicks == 10 and np.ptp(test.x) == pytest.approx(0.06, rel=0.05)
    assert 500 < float(np.max(test.force)) < 2000
