"""The parts of the discovered terms checked against closed forms: the play and reversal
operators of the feature library, the greedy selection, and the held-out refit of a form
in the binned space (a column only the left-out tests see is fitted on them)."""

from __future__ import annotations

import numpy as np

from shockdyno.diagnose.discover import (
    FoldRows,
    Rows,
    _phase_window,
    greedy,
    nested_gain,
    phase_words,
    plot_signal,
    predicted_structure,
)
from shockdyno.diagnose.features import FeatureTable, _time_features, play, travel_since_reversal


def test_the_play_operator_stands_still_until_the_input_has_moved_its_width() -> None:
    x = np.array([0.0, 1.0, 2.0, 3.0, 2.5, 2.0, 1.0, 0.0, 1.0])
    # half-width 0.5: follows 0.5 behind on the way up, holds for 1.0 after the turn
    got = play(x, 0.5, [0])
    assert np.allclose(got, [0.0, 0.5, 1.5, 2.5, 2.5, 2.5, 1.5, 0.5, 0.5])
    # two segments: each starts centred on its own first sample
    both = play(np.concatenate([x, x + 10.0]), 0.5, [0, x.size])
    assert np.allclose(both[x.size :], got + 10.0)


def test_travel_since_reversal_counts_from_each_change_of_direction() -> None:
    t = np.linspace(0.0, 2.0, 401)
    x = np.sin(np.pi * t)  # reverses at t = 0.5 and 1.5
    v = np.pi * np.cos(np.pi * t)
    s = travel_since_reversal(x, v, [0])
    i = int(np.searchsorted(t, 1.0))
    assert abs(s[i] - (1.0 - x[i])) < 1e-2  # from the top at x = 1
    j = int(np.searchsorted(t, 1.9))
    assert abs(s[j] - (x[j] + 1.0)) < 1e-2  # from the bottom at x = -1


def test_greedy_names_the_column_that_made_the_residual_and_not_its_neighbour() -> None:
    rng = np.random.default_rng(0)
    n = 400
    phi = rng.standard_normal((n, 6))
    phi[:, 1] = 0.8 * phi[:, 0] + 0.6 * phi[:, 1]  # a correlated neighbour of column 0
    r = 3.0 * phi[:, 0] - 1.0 * phi[:, 4] + 0.05 * rng.standard_normal(n)
    assert greedy(r, phi, range(6), 2) == [0, 4]
    assert greedy(r, phi, [1, 2, 3, 5], 1) == [1]  # only what it is allowed


def _rows(r: np.ndarray, jac: np.ndarray, phi: np.ndarray, test: np.ndarray) -> Rows:
    return Rows(r, np.zeros_like(r), jac, phi, test)


def test_a_held_out_test_is_predicted_with_its_own_columns_fitted_on_it() -> None:
    # Two tests of 40 bins; the model's columns: a shared offset, and an area of test 1
    # alone. Test 1 left out: its area column is unplaced by training and fitted on it.
    b = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    shape = np.sin(b)
    test = np.repeat([0, 1], 40)
    jac = np.column_stack([np.ones(80), np.r_[np.zeros(40), shape]])
    feature = np.cos(2 * b)
    phi = np.tile(feature, 2)[:, None]
    r = 5.0 * jac[:, 0] + 2.0 * jac[:, 1] + 3.0 * phi[:, 0]
    rows = _rows(r, jac, phi, test)
    train, held = rows.take([0]), rows.take([1])
    base, _ = predicted_structure(train, held, [])
    after, e = predicted_structure(train, held, [0])
    assert base > 100.0  # without the feature, 3 cos 2b is left on the held-out test
    assert abs(after) < 1e-9 and np.allclose(e, 0.0)
    gain, _, gains = nested_gain([FoldRows("test 1 left out", train, held)], [0], 1)
    assert gains == [gain] and gain > 0.999


def test_the_phase_window_holds_half_the_energy_and_is_worded_by_the_reversal_it_holds() -> None:
    energy = np.zeros(40)
    energy[9:12] = 1.0  # bins about 90°: full compression
    lo, hi = _phase_window(energy)
    assert 80.0 <= lo <= 90.0 and hi <= 110.0
    assert "full compression" in phase_words((lo, hi))
    assert "all round" in phase_words(_phase_window(np.ones(40), 0.9))


def test_a_drift_is_drawn_against_the_elapsed_time_not_its_settling_fraction() -> None:
    # 1 − e^(−t/3 min) runs 0…0.7 over a 4 min session with no unit: an axis labelled
    # "the elapsed time, settling over 3 min" must read minutes, as t does.
    t = np.linspace(0.0, 240.0, 50)
    cols = _time_features(t, None)
    table = FeatureTable(tuple(f for f, _ in cols), np.column_stack([c for _, c in cols]))
    drift = table.features[table.index("drift_180s")]
    shown = plot_signal(drift, table)
    assert (shown.key, shown.unit) == ("t", "s")
    other = FeatureTable(table.features[1:], table.values[:, 1:])  # no t in the library
    assert plot_signal(drift, other) is drift
