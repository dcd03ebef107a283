"""Trend degree selection on curves of known shape."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.fit.trend import polynomial_trend


def test_quadratic_like_eq9_is_recovered_with_degree_2() -> None:
    n = np.arange(1, 16)
    true = -2e-9 * n**2 + 2e-6 * n + 2e-6  # the paper's eq. 9 (m²)
    noisy = true * (1 + np.random.default_rng(0).normal(0, 1e-4, n.size))
    t = polynomial_trend(n, noisy)
    assert t is not None
    assert t.degree == 2
    np.testing.assert_allclose(t.coefficients, [-2e-9, 2e-6, 2e-6], rtol=0.05)
    assert t.r2 > 0.9999


def test_line_like_eq10_is_recovered_with_degree_1() -> None:
    n = np.arange(1, 16)
    true = 3e-7 * n + 1e-7  # eq. 10
    noisy = true + np.random.default_rng(1).normal(0, 1e-9, n.size)
    t = polynomial_trend(n, noisy)
    assert t is not None and t.degree == 1
    assert t.coefficients[0] == pytest.approx(3e-7, rel=0.01)


def test_few_points() -> None:
    assert polynomial_trend([], []) is None
    t = polynomial_trend([4], [2e-6])
    assert t is not None and t.degree == 0 and t.coefficients == (2e-6,)
