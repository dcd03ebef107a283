"""A test cut at a reversal ends where v is zero, and there the filtered velocity is an
extrapolation: a model with sharp friction takes either sign at those samples, and one
wild sample in one phase bin of one cycle dominated the cycle-to-cycle scatter the
diagnosis weighs every phase mean against (on a reference-plant sweep, a 55 N residual
made the noise of the phase means 21x what it is with the ends spared). The objective
samples spare the ends."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from shockdyno.diagnose.data import Data, time_halves
from shockdyno.fit.prepare import PreparedTest, prepare_tests
from shockdyno.fit.problem import prepared_inputs
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel, ModelInputs
from shockdyno.model.kinematics import extrapolated_samples
from shockdyno.model.spec import DamperSpec, load_spec
from shockdyno.record.types import TestData

STEP = 10  # 1 kHz recordings, 100 Hz objective


@pytest.fixture(scope="module")
def cut_at_reversals() -> tuple[DamperSpec, DamperModel, list[TestData]]:
    """Clicks 2/10 x 0.5/1/1.5 Hz, three cycles from the bottom of the stroke to the
    bottom, the force of the paper's model with sharp Coulomb friction (as the diagnosis's
    baseline calibrates it) plus 2 N of noise, 1 µm on the LVDT."""
    spec = load_spec(None).with_values({"friction_velocity_m_s": 1e-7})
    truth = DamperModel(spec)
    rng = np.random.default_rng(1)
    tests = []
    for td in synthetic_sweep(spec, [2, 10], cycles=3, seed=5):
        bc, bt = spec.bleed_areas(td.meta.clicks, 0)
        w = 2 * np.pi * td.meta.frequency_hz
        t = np.arange(round(3 / td.meta.frequency_hz * 1000) + 1) / 1000
        x, v, a = -0.03 * np.cos(w * t), 0.03 * w * np.sin(w * t), 0.03 * w * w * np.cos(w * t)
        f = truth.force(ModelInputs.single(x, v, a), float(bc), float(bt))
        noisy_x = x + rng.normal(0, 1e-6, t.size)
        noisy_f = f + rng.normal(0, 2.0, t.size)
        tests.append(replace(td, t=t, x=noisy_x, force=noisy_f, temperature=None))
    return spec, truth, tests


def _phase_mean_noise(spec: DamperSpec, truth: DamperModel, prepared: list[PreparedTest]) -> float:
    """Σ over tests and bins of the noise variance of the phase means of the true model's
    residual (N²): what the mismatch test and every candidate's bootstrap weigh against."""
    data = Data.build(spec, prepared)
    res = []
    for p in prepared:
        bc, bt = spec.bleed_areas(p.data.meta.clicks, 0)
        res.append(truth.force(prepared_inputs([p]), float(bc), float(bt)) - p.data.force[p.obj])
    return float(sum(np.sum(b.mean_var) for b in data.binned(np.concatenate(res))))


def test_the_ends_of_a_test_cut_at_reversals_do_not_set_the_noise(
    cut_at_reversals: tuple[DamperSpec, DamperModel, list[TestData]],
) -> None:
    spec, truth, tests = cut_at_reversals
    prepared, _ = prepare_tests(tests, 1000.0 / STEP)
    for p in prepared:
        edge = extrapolated_samples(p.data.t.size, 1e-3)
        assert edge >= 10
        assert p.obj[0] >= edge and p.obj[-1] < p.data.t.size - edge
        assert np.all(np.diff(p.obj) == STEP) and p.obj[0] % STEP == 0
    spared = _phase_mean_noise(spec, truth, prepared)
    # The same tests with every 10th sample from the first (what the objective took).
    every = [PreparedTest(p.data, p.v, p.a, np.arange(0, p.data.t.size, STEP)) for p in prepared]
    with_ends = _phase_mean_noise(spec, truth, every)
    # Measured: 424 N² spared, 1222 N² with the ends (white noise alone: ~86).
    assert spared < 0.6 * with_ends


def test_a_tests_halves_spare_its_ends_and_nothing_else(
    cut_at_reversals: tuple[DamperSpec, DamperModel, list[TestData]],
) -> None:
    _, _, tests = cut_at_reversals
    long = replace(tests[0], t=np.arange(8001) / 1000)  # 0.5 Hz: four cycles and a bit
    long = replace(long, x=-0.03 * np.cos(np.pi * long.t), force=1e3 * np.sin(np.pi * long.t))
    (p,), _ = prepare_tests([long], 1000.0 / STEP)
    halves = time_halves(p)
    assert halves is not None
    first, second = halves
    edge = extrapolated_samples(long.t.size, 1e-3)
    n_first = first.data.t.size
    assert first.obj[0] >= edge  # the test's start
    assert second.obj[-1] < second.data.t.size - edge  # the test's end
    # The cut between the halves is inside the test: nothing spared there.
    assert first.obj[-1] >= n_first - STEP and second.obj[0] == 0
