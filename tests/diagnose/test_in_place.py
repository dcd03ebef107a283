"""A named term must take the structure where its own force acts (diagnose/in_place.py).

Play in the LVDT's linkage (a worn rod end between the core and the ram) is no term's
physics: the recorded position stands still after each reversal while the ram takes up
the lash. A sensor lag fits part of it (p < alpha, a large own force), but acts on both
sides of every reversal where the play acts after it only, and leaves most of the
structure where it acts: it is not claimable. A real channel delay is: it takes all of it.
The sweeps are the library's own synthetic ones; the play (features.play, the backlash
operator) is applied to the recorded position, as the linkage applies it (the damper
itself moves without play).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from shockdyno.diagnose.candidates import Candidate, binned_means, try_candidate
from shockdyno.diagnose.claims import why_not
from shockdyno.diagnose.cycles import BinnedTest
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.features import play
from shockdyno.diagnose.fitting import refit
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.stats import noise_draws
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec
from shockdyno.record.types import TestData


def _sensor_candidate(tests: list[TestData]) -> tuple[Candidate, Data]:
    spec = load_spec(None)
    prepared, _ = prepare_tests(tests, 100.0, phase_locked=True)
    data = Data.build(spec, prepared)
    base = refit(data, DamperModel(spec), (), None, max_nfev=30)
    means, binned = binned_means(data, base.residual)
    noise = noise_draws(binned, np.random.default_rng(0), 199)
    return try_candidate(data, base, means, "sensor_lag", noise, 15), data


def test_a_sensor_lag_is_not_claimed_for_play_in_the_lvdt_linkage() -> None:
    spec = load_spec(None)
    tests = synthetic_sweep(spec, [2, 10, 20], cycles=3, seed=3)
    played = [dataclasses.replace(t, x=play(t.x, 3e-4, [0])) for t in tests]
    c, data = _sensor_candidate(played)
    s = Settings()
    # It fits something, significantly and with a force of its own ...
    assert c.p_value < s.alpha and c.own_peak_n > 50.0, (c.p_value, c.own_peak_n)
    # ... but leaves most of the structure where that force acts.
    said = why_not(c, {"sensor_lag": (0.5, "")}, s, 5.0, x=data.prob.inputs.x)
    assert said.startswith("not its physics"), said
    assert "where its own force acts" in said
    assert c.in_place < 0.35, c.in_place


def test_a_real_channel_delay_takes_the_structure_where_it_acts() -> None:
    spec = load_spec(None)
    tests = synthetic_sweep(spec, [2, 10, 20], cycles=3, force_delay_s=0.003, seed=3)
    c, data = _sensor_candidate(tests)
    assert why_not(c, {"sensor_lag": (0.9, "")}, Settings(), 5.0, x=data.prob.inputs.x) == ""
    assert c.in_place > 0.9, c.in_place


def _binned(mean: np.ndarray, var: float) -> list[BinnedTest]:
    n = mean.size
    cells = np.tile(mean, (3, 1))
    return [BinnedTest(cells, mean, np.full(n, var), 1.0, np.full((3, n), 5.0))]


def test_the_share_is_of_the_structure_where_the_term_acts_less_its_noise() -> None:
    """Bins where the term's own force is under a tenth of its largest do not count; the
    noise variance of a phase mean is not structure; bins with no structure give 0."""
    from shockdyno.diagnose.in_place import in_place_share

    own = np.array([0.0, 0.05, 1.0, 0.5, 0.2])
    before = np.array([9.0, 9.0, 4.0, 2.0, 2.0])
    var = 0.5
    after = np.array([9.0, 0.0, 1.0, 1.0, 1.0])  # the second bin is not where it acts
    there = (16 - var) + (4 - var) + (4 - var)
    left = (1 - var) * 3
    assert np.isclose(in_place_share(own, _binned(before, var), after), 1 - left / there)
    quiet = np.array([9.0, 9.0, 0.5, 0.5, 0.5])
    assert in_place_share(own, _binned(quiet, 0.5), after) == 0.0
