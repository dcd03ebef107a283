"""How far the recording's noise moves a term's share where its own force acts
(in_place.share_noise_sd), and what the verdict says when the claim's threshold lies within
it: a refusal says the recording cannot tell, a claim says it is borderline. Neither
changes what is claimed."""

from __future__ import annotations

import dataclasses

import numpy as np
from test_in_place import _candidate

from shockdyno.diagnose.claims import borderline, why_not
from shockdyno.diagnose.cycles import N_BINS, BinnedTest, bin_residual, phase_of
from shockdyno.diagnose.in_place import in_place_share, share_noise_sd
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.stats import noise_draws
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.spec import load_spec

CYCLES = 8
PER_BIN = 5


def _recorded(structure: np.ndarray, noise_n: float, seed: int) -> list[BinnedTest]:
    """A test of CYCLES sine cycles whose residual is `structure` (one value a phase bin)
    plus white noise, binned as the diagnosis bins it."""
    n = CYCLES * N_BINS * PER_BIN
    t = np.arange(n) / (N_BINS * PER_BIN)
    x = np.sin(2 * np.pi * t - np.pi / 2)
    phase = phase_of(t, x)
    r = structure[phase.bin] + np.random.default_rng(seed).normal(0.0, noise_n, n)
    return [bin_residual(r, phase)]


def test_the_shares_spread_is_the_noises_and_grows_with_it() -> None:
    own = np.zeros(N_BINS)
    own[5:9] = 1.0  # where the term acts
    structure = np.where(own > 0, 6.0, 0.0)
    spreads = []
    for noise_n in (1.0, 2.0, 4.0):
        before = _recorded(structure, noise_n, 1)
        after = before[0].mean - 0.5 * structure  # the refit takes half of it
        draws = noise_draws(before, np.random.default_rng(2), 999)
        share = in_place_share(own, before, after)
        assert 0.4 < share < 0.8  # half the structure, read through the noise
        spreads.append(share_noise_sd(own, before, after, draws))
    # Twice the noise, about twice the spread (the structure well above the noise).
    assert 1.5 < spreads[1] / spreads[0] < 2.6, spreads
    assert 1.5 < spreads[2] / spreads[1] < 2.6, spreads
    # No draws, no term of its own: nothing read.
    assert share_noise_sd(own, before, after, np.zeros((N_BINS, 0))) == 0.0
    assert share_noise_sd(np.zeros(N_BINS), before, after, draws) == 0.0


def test_a_share_within_its_noise_of_the_threshold_is_said_so_and_decides_nothing() -> None:
    spec = load_spec(None)
    tests = synthetic_sweep(spec, [2, 10, 20], cycles=3, force_delay_s=0.003, seed=3)
    c, data, _ = _candidate(tests, "sensor_lag")
    s = Settings()
    x = data.prob.inputs.x
    scored = {"sensor_lag": (0.9, "")}
    # The real delay, claimable, takes all of its place: far from the threshold.
    assert why_not(c, scored, s, 5.0, x=x) == ""
    assert c.in_place_sd > 0 and c.in_place - 2 * c.in_place_sd > s.min_in_place
    assert borderline(c, s) == ""
    # Under the threshold by less than twice its noise: refused as before, and said.
    near = dataclasses.replace(c, in_place=0.46, in_place_sd=0.12)
    said = why_not(near, scored, s, 5.0, x=x)
    assert said.startswith("not its physics: it removes 46 %"), said
    assert "±12 %" in said and "cannot tell" in said
    far = dataclasses.replace(c, in_place=0.2, in_place_sd=0.12)
    assert "cannot tell" not in why_not(far, scored, s, 5.0, x=x)
    # Over it by less than twice its noise: claimable as before, and borderline.
    over = dataclasses.replace(c, in_place=0.51, in_place_sd=0.13)
    assert why_not(over, scored, s, 5.0, x=x) == ""
    said = borderline(over, s)
    assert said.startswith("borderline: where its own force acts it removes 51 ± 13 %"), said
