"""A sample on a force step the converter did not resolve at a turn is no evidence
(diagnose/data.step_at_turn).

At a closed bleed the force steps by the two valves' preloads (over a kN) as the ram
turns. A load cell read by an averaging converter reports, for the sample whose interval
holds the turn, a share of each side set by where the turn fell; the model, evaluated at
the sample's instant, is on one side. The sweep here is the library's own model, made at
ten times the rate and averaged over each sample's millisecond as such a converter does,
so the model is the truth: its residual must hold no structure beyond the load cell's
noise.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from shockdyno.diagnose.data import Data, step_at_turn
from shockdyno.diagnose.stats import mismatch_test
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec
from shockdyno.record.types import TestData

NOISE_N = 3.0
FINE = 10  # model samples per recorded sample


def _averaged(spec_clicks: list[int], lag_s: float) -> list[TestData]:
    """The sweep as a 1 kHz converter records it: each force sample the mean over its own
    millisecond (a box centred on the sample), the LVDT read at the instant."""
    spec = load_spec(None)
    fine = synthetic_sweep(
        spec,
        spec_clicks,
        [0.5, 1.0],
        cycles=6,
        sample_rate_hz=1000.0 * FINE,
        lvdt_noise_m=0.0,
        lvdt_lsb_m=0.0,
        load_noise_n=0.0,
        load_lsb_n=0.0,
        ripple_m=0.0,
        tracking_lag_s=lag_s,
        seed=1,
    )
    rng = np.random.default_rng(2)
    box = np.r_[0.5, np.ones(FINE - 1), 0.5] / FINE
    half = FINE // 2
    out = []
    for t in fine:
        force = np.convolve(t.force, box, mode="same")[half:-half:FINE]
        n = force.size
        out.append(
            dataclasses.replace(
                t,
                meta=dataclasses.replace(t.meta, sample_rate_hz=1000.0),
                t=t.t[half:-half:FINE],
                x=t.x[half:-half:FINE] + rng.normal(0.0, 1e-6, n),
                force=force + rng.normal(0.0, NOISE_N, n),
            )
        )
    return out


def _truth_residual(tests: list[TestData]) -> tuple[Data, np.ndarray]:
    spec = load_spec(None)
    prepared, _ = prepare_tests(tests, 200.0, phase_locked=True)
    data = Data.build(spec, prepared)
    model = DamperModel(spec)
    areas = [spec.bleed_areas(c, g) for c, g, _ in data.prob.keys]
    bc = np.array([float(a[0]) for a in areas])
    bt = np.array([float(a[1]) for a in areas])
    return data, data.prob.for_model(model).force(model, bc, bt) - data.prob.f


def test_a_closed_bleeds_step_at_reversal_leaves_the_truth_no_structure() -> None:
    # The turn's place within its sample moves with the servo's lag: two places.
    for lag_s in (0.0, 0.00035):
        tests = _averaged([0], lag_s)
        data, r = _truth_residual(tests)
        stepped = np.max(np.abs(r))
        assert stepped > 30 * NOISE_N  # the sweep does hold a sample on the step
        stat = mismatch_test(data.binned(r), np.random.default_rng(0), 499)
        assert stat.p_value > 0.05
        assert abs(stat.noise_floor_n - NOISE_N) < 0.2 * NOISE_N


def test_only_the_samples_either_side_of_a_turn_are_left_out() -> None:
    tests = _averaged([0, 10], 0.0)
    spec = load_spec(None)
    prepared, _ = prepare_tests(tests, 200.0, phase_locked=True)
    left = 0
    for p in prepared:
        out = step_at_turn(p.v, p.data.force, p.obj)
        turns = np.flatnonzero(np.sign(p.v[1:]) != np.sign(p.v[:-1]))
        # Each left-out sample is within one sample of a turn (between turns[i] and
        # turns[i] + 1), and no turn takes more than the two samples that close to it.
        near = np.min(np.abs(p.obj[out][:, None] - (turns[None, :] + 0.5)), axis=1)
        assert np.all(near <= 1.5)
        assert np.sum(out) <= 2 * turns.size
        left += int(np.sum(out))
    assert left > 0
    data = Data.build(spec, prepared)
    assert sum(int(np.sum(ph.cycle < 0)) for ph in data.phases) >= sum(
        int(np.sum(step_at_turn(p.v, p.data.force, p.obj))) for p in prepared
    )
