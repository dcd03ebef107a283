"""How a fold's held-out structure is totalled for a term that acts on some tests only."""

import numpy as np
import pytest

from shockdyno.diagnose.candidates import judged_structure


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
