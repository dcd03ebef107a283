"""How a fold's held-out structure is totalled for a term that acts on some tests only."""

import numpy as np
import pytest

from shockdyno.diagnose.candidates import judged_structure, median_gain


def gain(base: list[float], cand: list[float], acts: list[bool]) -> float:
    before, after = judged_structure(np.array(base), np.array(cand), np.array(acts))
    return 1.0 - after / before


def test_a_local_effect_is_judged_where_it_acts_not_diluted() -> None:
    # The term removes all the structure of the one test it acts on; the other two keep
    # a misfit it has nothing to do with.
    assert gain([4.0, 9.0, 9.0], [0.0, 9.0, 9.0], [True, False, False]) == 1.0
    # Over all three tests the same fit would have removed 4 of 22.
    assert gain([4.0, 9.0, 9.0], [0.0, 9.0, 9.0], [True, True, True]) == pytest.approx(4.0 / 22.0)


def test_harm_where_it_does_not_act_counts_against_it() -> None:
    assert gain([4.0, 9.0], [0.0, 13.0], [True, False]) == 0.0
    assert gain([4.0, 9.0], [2.0, 15.0], [True, False]) < 0.0


def test_what_it_removes_elsewhere_is_credited_and_the_gain_stays_at_most_one() -> None:
    # Acts on the first (4 → 1), and removes 6 of 9 on the second: judged on 4 + 6.
    assert gain([4.0, 9.0], [1.0, 3.0], [True, False]) == pytest.approx(1.0 - 1.0 / 10.0)
    rng = np.random.default_rng(3)
    for _ in range(200):
        b, c = rng.normal(5, 5, 6), rng.normal(3, 5, 6)
        acts = rng.random(6) < 0.5
        acts[0] = True
        before, after = judged_structure(b, c, acts)
        assert before > 0 or np.all(b[acts] <= 0)
        if before > 0:
            assert 1.0 - after / before <= 1.0 + 1e-12


def test_negative_structure_is_noise_and_counts_as_none() -> None:
    # Phase means less their noise variance can go below zero: that is "no structure".
    assert gain([-1.0, 4.0], [-3.0, 1.0], [False, True]) == 0.75


def test_one_fold_that_extrapolates_wildly_does_not_decide() -> None:
    """Folds vote by their median: the air beside a heat term took four folds from
    28-81 N to 2.5-5.6 N RMS, and the fifth, whose heat term trained without the stiffest
    click, from 110 to 623 N (a held-out-plant sweep). Pooled, that fold alone gave -10.6
    (weighted by each fold's tests; here by the printed RMS alone)."""
    before = np.array([43.1, 62.4, 81.3, 110.0, 28.5]) ** 2
    after = np.array([5.64, 3.89, 5.1, 623.0, 2.49]) ** 2
    pooled = 1 - after.sum() / before.sum()
    assert pooled < -10
    assert median_gain(list(1 - after / before), []) > 0.98
    # A term that only mends the wild fold (a position force fitted to it) gains in one
    # fold of five: pooled that was a gain of 1.0, voted it is about none.
    mend = np.array([5.55, 3.71, 5.14, 6.65, 2.45]) ** 2
    base = np.array([5.62, 3.77, 5.15, 630.0, 2.46]) ** 2
    assert 1 - mend.sum() / base.sum() > 0.99
    assert median_gain(list(1 - mend / base), []) < 0.05


def test_only_folds_the_term_reaches_vote_and_no_fold_is_no_gain() -> None:
    assert median_gain([0.9, 0.8], [0.0, 0.01, -0.02]) == pytest.approx(0.85)
    assert median_gain([], [0.0, 0.2, 0.1]) == pytest.approx(0.1)
    assert median_gain([], []) == 0.0
