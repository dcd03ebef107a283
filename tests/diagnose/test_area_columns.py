"""A chamber's state carries a bleed area's effect past reversal: the Jacobian's area
columns must say so, or the fit stops where a step would not descend. On a sim-rig sweep
with 0.3 % air the diagnosis ended at 0.39 % air in stiffer oil, with 1.7e-8 m² of bleed
on the closed click, its phase means 20x the truth's squared error; refitted with exact
columns from there it went to 0.299 % (a fresh term-library seed, bench_diagnose)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from shockdyno.diagnose.candidates import AREA_SCALE, binned_jacobian
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import refit
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec
from shockdyno.model.terms import make_term
from shockdyno.record import open_recording
from shockdyno.run.plan import SweepPlan
from shockdyno.run.recording import record_sweep
from shockdyno.simrig import start_sim_rig

REPO = Path(__file__).resolve().parents[2]
AIR = {"compressibility.air_fraction": 0.003}


def test_the_binned_area_columns_are_each_areas_own_difference() -> None:
    spec = load_spec(None)
    prepared, _ = prepare_tests(synthetic_sweep(spec, [0, 14], cycles=2, seed=5))
    data = Data.build(spec, prepared)
    model = DamperModel(spec, (make_term("compressibility"),)).with_values(AIR)
    fitted = refit(data, model, (), None, max_nfev=3)
    jac, ng = binned_jacobian(data, fitted)
    bc, bt = fitted.area_vectors(data)
    n = bc.size
    prob = data.prob.for_model(fitted.model)
    for j in range(2 * n):
        step = np.zeros(2 * n)
        step[j] = max(1e-3 * np.concatenate([bc, bt])[j], 1e-10)
        moved = prob.force(fitted.model, bc + step[:n], bt + step[n:])
        want = data.bin_matrix(((moved - fitted.force) / step[j])[:, None])[:, 0]
        got = jac[:, ng + j] / AREA_SCALE
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9 * np.max(np.abs(want)))
    # Across reversal: the closed click's compression area moves rebound samples too.
    rebound = prob.problem == n  # group 0's rebound samples
    assert np.any(rebound)


@pytest.mark.timeout(300)
def test_an_aerated_fit_leaves_a_leaky_closed_click(tmp_path: Path) -> None:
    rec = tmp_path / "air.mcap"
    sc = tmp_path / "air.toml"
    sc.write_text(
        "[scenario]\nname = 'air'\n[[term]]\nkind = 'compressibility'\nair_fraction = 0.003\n"
    )
    plan = SweepPlan(
        clicks=(0, 14), frequencies_hz=(0.5, 1.0, 1.5), warmup_cycles=1, measured_cycles=2
    )
    with start_sim_rig(REPO / "rigs" / "sim.toml", speed=50, seed=31, scenario=sc) as sim:
        record_sweep(
            sim.rig_config(), plan, rec, metadata={"damper_id": "air"}, console=Console(quiet=True)
        )
    spec = load_spec(None)
    prepared, _ = prepare_tests(open_recording(rec).load_all(), 100.0, phase_locked=True)
    data = Data.build(spec, prepared)
    free = (*AIR, "compressibility.oil_compressibility_per_gpa")
    truth = DamperModel(spec, (make_term("compressibility"),)).with_values(AIR)
    good = refit(data, truth, free, None, max_nfev=60)
    # Where the diagnosis stopped: more air in stiffer oil, a leak on the closed click.
    stuck = truth.with_values(
        {
            "compressibility.air_fraction": 0.0039,
            "compressibility.oil_compressibility_per_gpa": 0.44,
        }
    )
    areas = dict(good.areas)
    areas[(0, 0)] = (1.66e-8, 5.29e-8)
    got = refit(data, stuck, free, replace(good, areas=areas), max_nfev=60)
    ss = float(got.residual @ got.residual)
    assert ss <= 1.05 * float(good.residual @ good.residual)
    assert got.model.value("compressibility.air_fraction") == pytest.approx(0.003, rel=0.05)


@pytest.mark.parametrize(
    ("values", "state"),
    [
        ({"sensor_lag.delay_s": 0.006}, False),
        ({"sensor_lag.delay_s": 0.006, "sensor_lag.lvdt_lag_s": 0.002}, False),
        ({"sensor_lag.delay_s": 0.006, "sensor_lag.load_cell_lag_s": 0.004}, True),
    ],
)
def test_only_a_lag_that_carries_state_takes_the_exact_columns(
    values: dict[str, float], state: bool
) -> None:
    """The plain fit carries the channel delay: with no load-cell lag a sample's force
    follows its own delayed motion, so the split by the delayed direction is exact and
    costs one evaluation less per Jacobian. A load-cell lag runs an area past reversal."""
    spec = load_spec(None)
    prepared, _ = prepare_tests(synthetic_sweep(spec, [0, 14], cycles=2, seed=5))
    data = Data.build(spec, prepared)
    model = DamperModel(spec, (make_term("sensor_lag"),)).with_values(values)
    assert model.carries_state(("sensor_lag.delay_s",)) is state
    prob = data.prob.for_model(model, ("sensor_lag.delay_s",))
    bc = np.array([float(spec.bleed_areas(c, g)[0]) for c, g, _ in data.prob.keys])
    bt = np.array([float(spec.bleed_areas(c, g)[1]) for c, g, _ in data.prob.keys])
    f0 = prob.force(model, bc, bt)
    _, v, _ = model.motion(prob.inputs)  # the split calibrate.py makes
    moved = prob.force(model, bc * 1.01, bt) - f0  # the compression areas only
    assert np.any(moved[v > 0] != 0)
    crossed = np.abs(moved[v < 0])  # rebound samples (by the delayed motion)
    assert bool(np.max(crossed) > 0) is state, np.max(crossed)  # exactly 0 without state
    # Free the lag and it carries state whatever its value.
    free = ("sensor_lag.delay_s", "sensor_lag.load_cell_lag_s")
    assert DamperModel(spec, (make_term("sensor_lag"),)).carries_state(free)
