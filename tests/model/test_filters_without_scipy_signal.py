"""The project's Savitzky–Golay differentiator and first-order lag filter give
scipy.signal's numbers (the project does not import scipy.signal in a fit, a diagnosis or
a report: its import takes a second or two at every start of a command)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.signal import lfilter, savgol_filter

from shockdyno.model.filters import first_order_lag, lag_coefficients
from shockdyno.model.kinematics import differentiate, savgol

SIZES = [(n, w) for n in (7, 8, 61, 2000) for w in (5, 7, 25, 51) if w <= n]


@pytest.mark.parametrize(("n", "window"), SIZES)
@pytest.mark.parametrize("deriv", [1, 2])
def test_savgol_is_scipys_interp_mode(n: int, window: int, deriv: int) -> None:
    rng = np.random.default_rng(n + window)
    x = 0.03 * np.sin(np.arange(n) * 0.02) + rng.normal(0, 5e-6, n).cumsum()
    want = savgol_filter(x, window, 3, deriv=deriv, delta=1e-3, mode="interp")
    got = savgol(x, window, 3, deriv, 1e-3)
    # The same sums in another order: a second derivative over 5 samples of 1 ms divides
    # differences of 0.03 m values by 1e-6 s², so their rounding alone is ~1e-12 of the
    # result, and numpy's vector paths differ by machine (1.5e-12 on an AVX-512 Xeon).
    # An error in the filter's coefficients or its ends is orders above 1e-10.
    assert np.max(np.abs(got - want)) <= 1e-10 * np.max(np.abs(want))


def test_differentiate_a_sine_gives_its_velocity_and_acceleration() -> None:
    t = np.arange(0, 2.0, 1e-3)
    w = 2 * np.pi * 1.5
    v, a = differentiate(t, 0.03 * np.sin(w * t))
    assert np.max(np.abs(v - 0.03 * w * np.cos(w * t))) < 1e-3 * 0.03 * w
    inner = slice(20, -20)  # the ends: a cubic over one window, not the sine
    assert np.max(np.abs(a - -0.03 * w**2 * np.sin(w * t))[inner]) < 2e-3 * 0.03 * w**2


def test_lag_filter_is_lfilter_with_its_state() -> None:
    u = np.random.default_rng(1).normal(size=3000)
    b0, b1, e = lag_coefficients(0.004, 1e-3)
    want, zf = lfilter([b0, b1], [1.0, -e], u, zi=[0.25])
    got, state = first_order_lag(u, 0.004, np.array([0]), np.array([1e-3]), carry=np.array([0.25]))
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(state, zf)


def test_a_lag_split_in_chunks_is_the_lag_in_one_call() -> None:
    u = np.sin(np.arange(4000) * 0.01)
    dt = np.array([1e-3])
    whole, _ = first_order_lag(u, 0.01, np.array([0]), dt)
    first, carry = first_order_lag(u[:1500], 0.01, np.array([0]), dt)
    second, _ = first_order_lag(u[1500:], 0.01, np.array([0]), dt, carry=carry)
    np.testing.assert_allclose(np.concatenate([first, second]), whole, rtol=0, atol=1e-15)


def test_fit_diagnose_and_report_do_not_import_scipy_signal() -> None:
    code = (
        "import sys; import shockdyno.cli, shockdyno.fit.sweep, shockdyno.diagnose.engine, "
        "shockdyno.report.build; import numpy as np; from shockdyno.model.kinematics import "
        "differentiate; differentiate(np.arange(100) * 1e-3, np.zeros(100)); "
        "print('scipy.signal' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.stdout.strip() == "False", done.stderr


def test_the_sim_rigs_servo_filter_is_scipys_bilinear_at_rest_then_driven() -> None:
    from scipy.signal import bilinear, lfiltic

    from shockdyno.model.filters import biquad
    from shockdyno.simrig.engine import at_rest, servo_filter

    wn, zeta, fs = 2 * np.pi * 60.0, 0.8, 1000.0
    b_want, a_want = bilinear([wn * wn], [1.0, 2 * zeta * wn, wn * wn], fs=fs)
    b, a = servo_filter(60.0, zeta, fs)
    np.testing.assert_allclose(b, b_want, rtol=1e-12)
    np.testing.assert_allclose(a, a_want, rtol=1e-12, atol=1e-15)
    zi_want = lfiltic(b_want, a_want, [0.075, 0.075], [0.075, 0.075])
    np.testing.assert_allclose(at_rest(b, a, 0.075), zi_want, rtol=1e-12)
    u = 0.075 + 0.02 * np.sin(np.arange(2000) * 2 * np.pi / 1000.0)
    want, zf_want = lfilter(b_want, a_want, u, zi=zi_want)
    got, zf = biquad(b, a, u, at_rest(b, a, 0.075))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(zf, zf_want, rtol=0, atol=1e-15)
    assert abs(got[-1] - 0.075) < 1e-3  # a 60 Hz servo follows a 1 Hz sine closely


def test_a_periodic_lag_is_the_state_many_cycles_of_the_same_motion_reach() -> None:
    """`periodic`: each segment starts in the state it ends in, as after many repeats of
    its cycles (the last of 60 repeats filtered by lfilter from rest)."""
    n = 400
    seg = np.sin(2 * np.pi * np.arange(n) / n) + 0.3 * np.cos(6 * np.pi * np.arange(n) / n)
    dt = 1e-3
    for tau in (0.002, 0.02, 0.2):
        b0, b1, e = lag_coefficients(tau, dt)
        many, _ = lfilter([b0, b1], [1.0, -e], np.tile(seg, 60), zi=[0.0])
        got, _ = first_order_lag(
            np.tile(seg, 2), tau, np.array([0, n]), np.full(2, dt), periodic=True
        )
        np.testing.assert_allclose(got[:n], many[-n:], rtol=0, atol=1e-12)
        np.testing.assert_allclose(got[n:], many[-n:], rtol=0, atol=1e-12)
