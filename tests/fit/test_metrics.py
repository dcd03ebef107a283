"""E_t, E_x, E_xd (eq. 11-17) and eq. 8 against integrals worked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shockdyno.errors import ConfigError, FitError
from shockdyno.fit.metrics import error_metrics, objective

RATE = 1000.0
A = 0.03  # m
FREQ = 1.0
W = 2 * math.pi * FREQ
CYCLES = 2
T = CYCLES / FREQ


@pytest.fixture
def sine() -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(round(T * RATE) + 1) / RATE
    return t, A * np.sin(W * t)


def test_constant_offset_on_a_sinusoid(sine: tuple[np.ndarray, np.ndarray]) -> None:
    t, x = sine
    f0, c = 800.0, 25.0
    f_exp = f0 * np.sin(W * t)
    e = error_metrics(t, x, f_exp, f_exp + c)
    sigma = f0 * math.sqrt(T / 2)  # ∫ (F0 sin)² over whole cycles
    # ∫ |dx/dt| dt is the distance travelled, 4A per cycle; ∫ |dẋ/dt| dt is 4Aω per cycle.
    assert e["E_t"] == pytest.approx(c * math.sqrt(T) / sigma, rel=1e-6)
    assert e["E_x"] == pytest.approx(c * math.sqrt(4 * A * CYCLES) / sigma, rel=1e-3)
    assert e["E_xd"] == pytest.approx(c * math.sqrt(4 * A * W * CYCLES) / sigma, rel=1e-3)


@pytest.mark.parametrize("k", [0.5, 0.9, 1.2])
def test_scaled_copy(sine: tuple[np.ndarray, np.ndarray], k: float) -> None:
    t, x = sine
    f0, mean = 600.0, 250.0  # a gas-force offset: σ_F is about the mean, ε_t is not
    f_exp = mean + f0 * np.sin(W * t)
    e = error_metrics(t, x, f_exp, k * f_exp)
    assert e["E_t"] == pytest.approx(abs(1 - k) * math.sqrt(1 + 2 * mean**2 / f0**2), rel=1e-6)


def test_weights_of_a_sine_displacement(sine: tuple[np.ndarray, np.ndarray]) -> None:
    """Residual D cos(ωt): ∫ D² cos² · Aω|cos| dt = D² A ω T 4/(3π);
    ∫ D² cos² · Aω²|sin| dt = D² A ω² T 2/(3π)."""
    t, x = sine
    f0, d = 700.0, 40.0
    f_exp = f0 * np.sin(W * t)
    e = error_metrics(t, x, f_exp, f_exp + d * np.cos(W * t))
    sigma = f0 * math.sqrt(T / 2)
    assert e["E_t"] == pytest.approx(d * math.sqrt(T / 2) / sigma, rel=1e-6)
    assert e["E_x"] == pytest.approx(d * math.sqrt(A * W * T * 4 / (3 * math.pi)) / sigma, rel=1e-3)
    assert e["E_xd"] == pytest.approx(
        d * math.sqrt(A * W**2 * T * 2 / (3 * math.pi)) / sigma, rel=2e-3
    )


def test_weights_are_robust_to_lvdt_noise(sine: tuple[np.ndarray, np.ndarray]) -> None:
    t, x = sine
    rng = np.random.default_rng(3)
    noisy = x + rng.normal(0, 5e-6, x.size)
    f_exp = 700.0 * np.sin(W * t)
    f_model = f_exp + 40.0 * np.cos(W * t)
    clean, dirty = error_metrics(t, x, f_exp, f_model), error_metrics(t, noisy, f_exp, f_model)
    for key in ("E_x", "E_xd"):
        assert dirty[key] == pytest.approx(clean[key], rel=0.02)


def test_perfect_model_has_zero_error(sine: tuple[np.ndarray, np.ndarray]) -> None:
    t, x = sine
    f = 300.0 + 500 * np.sin(W * t)
    assert error_metrics(t, x, f, f) == {"E_t": 0.0, "E_x": 0.0, "E_xd": 0.0}


def test_objective_is_sum_of_absolute_differences() -> None:
    assert objective([1.0, -2.0, 3.5], [0.0, 1.0, 3.0]) == pytest.approx(1 + 3 + 0.5)


def test_bad_inputs_are_typed_errors(sine: tuple[np.ndarray, np.ndarray]) -> None:
    t, x = sine
    f = np.sin(W * t)
    with pytest.raises(FitError):
        error_metrics(t, x, f, f[:-1])
    with pytest.raises(FitError):
        error_metrics(t, x, np.ones_like(t), f)  # σ_F = 0
    jittered = t.copy()
    jittered[5] += 0.4 / RATE
    with pytest.raises(ConfigError):
        error_metrics(jittered, x, f, f)
