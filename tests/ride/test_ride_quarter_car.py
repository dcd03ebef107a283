"""The quarter-car integrator against linear theory, and the damper table against the model."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest
from scipy.signal import welch

from shockdyno.errors import ConfigError
from shockdyno.model import DamperModel, damper_force, load_spec
from shockdyno.model.composite import CHAMBER, Term, Work
from shockdyno.model.quarter_car import (
    LinearDamper,
    QuarterCar,
    TabulatedDamper,
    accel_transfer,
    simulate,
    stable_step,
)
from shockdyno.model.road import class_psd, road_psd, synthesize_road

CAR = QuarterCar()
SPEC = load_spec()


def _linear_run(c: float, start_c: float, seconds: float = 20.0, dt: float = 1e-3):
    speed = 60 / 3.6
    road = synthesize_road(class_psd("C"), speed * seconds, seed=5)
    n = round(seconds / dt)
    traj = simulate(
        CAR, LinearDamper(np.array([c])), road.period_samples(2 * n)[None, :], dt,
        n_warmup=round(8.0 / dt), start_c_ns_m=start_c,
    )  # fmt: skip
    return road, traj, speed


def test_linear_car_matches_its_transfer_function_line_by_line() -> None:
    """From a wrong start (another damper's steady state), after the warm-up every road
    harmonic comes out as |H(ω)| S_n, and the RMS is the analytic integral."""
    c = 1500.0
    road, traj, _ = _linear_run(c, start_c=4000.0)
    acc = traj.sprung_accel_m_s2[0]
    n = acc.size
    amp = np.abs(np.fft.rfft(acc))[road.harmonic] * 2 / n
    omega_t = 2 * math.pi * road.harmonic / (n * traj.dt_s)
    theory = accel_transfer(CAR, c, omega_t) * road.amplitude_m
    in_band = omega_t / (2 * math.pi) <= 20.0
    np.testing.assert_allclose(amp[in_band], theory[in_band], rtol=0.01)
    rms_theory = math.sqrt(np.sum(theory**2) / 2)
    assert float(np.sqrt(np.mean(acc**2))) == pytest.approx(rms_theory, rel=1e-3)


def test_linear_car_welch_psd_matches_h_squared_times_road_psd() -> None:
    """The Welch PSD the study reports, against |H(ω)|² S_road, band by band, 0.3-20 Hz.

    One road's Welch estimate scatters by ~10 % in a narrow band (a few dozen harmonics
    with random phases beat within each segment), so the PSD is averaged over 8 seeds,
    integrated at once as 8 runs."""
    c, speed, seconds, dt = 2500.0, 60 / 3.6, 60.0, 2e-3
    n = round(seconds / dt)
    roads = np.array(
        [
            synthesize_road(class_psd("C"), speed * seconds, seed=s).period_samples(2 * n)
            for s in range(8)
        ]
    )
    traj = simulate(CAR, LinearDamper(np.full(8, c)), roads, dt, round(4.0 / dt), c)
    f, p = welch(traj.sprung_accel_m_s2, fs=1 / dt, nperseg=4096, axis=1)
    f, p = f[1:], np.mean(p[:, 1:], axis=0)  # S_g is infinite at Ω = 0
    omega_road = 2 * math.pi * f / speed
    s_time = road_psd(omega_road, class_psd("C")) * 2 * math.pi / speed  # m²/Hz
    theory = accel_transfer(CAR, c, 2 * math.pi * f) ** 2 * s_time
    # Below 1 Hz a band holds only a few 0.12 Hz Welch bins on a steep (∝ f²) spectrum:
    # the window's smoothing biases it up by ~5-10 %; from 1 Hz on, within 5 %.
    edges = [0.3, 0.6, 1.0, 1.5, 2.0, 3.0, 5.0, 8.0, 10.0, 12.0, 15.0, 20.0]
    for lo, hi in itertools.pairwise(edges):
        sel = (f >= lo) & (f < hi)
        tol = 0.05 if lo >= 1.0 else 0.15
        assert np.mean(p[sel]) / np.mean(theory[sel]) == pytest.approx(1.0, abs=tol), (lo, hi)


def test_rms_scales_with_the_square_root_of_road_psd() -> None:
    speed, seconds, dt = 80 / 3.6, 10.0, 1e-3
    n = round(seconds / dt)
    base = synthesize_road(1e-6, speed * seconds, seed=9).period_samples(2 * n)
    roads = np.array([base, 3.0 * base])  # PSD × 9
    traj = simulate(CAR, LinearDamper(np.array([2000.0, 2000.0])), roads, dt, 2000)
    rms = np.sqrt(np.mean(traj.sprung_accel_m_s2**2, axis=1))
    assert rms[1] / rms[0] == pytest.approx(3.0, rel=1e-9)


def test_more_linear_damping_past_the_optimum_raises_body_acceleration() -> None:
    """Classical quarter-car theory on road A at 20 km/h: RMS(c) falls to a minimum near
    ζ ≈ 0.3 (c ≈ 3 kN·s/m here) and rises after it. The fitted damper's low-speed rates
    (6-8 kN·s/m) lie past it, which is why fewer clicks ride harsher (test_ride_study)."""
    speed = 20 / 3.6
    f = np.linspace(0.05, 60.0, 60_000)
    s_time = road_psd(2 * math.pi * f / speed, class_psd("A")) * 2 * math.pi / speed
    rates = [500.0, 1500.0, 3000.0, 6000.0, 8000.0]
    rms = [
        math.sqrt(np.trapezoid(accel_transfer(CAR, c, 2 * math.pi * f) ** 2 * s_time, f))
        for c in rates
    ]
    assert rms[0] > rms[1] > rms[2] < rms[3] < rms[4]


def test_damper_table_matches_the_full_model_per_run() -> None:
    """Runs of different clicks interleaved: table force + inertia + rest force = model."""
    settings = [tuple(float(a) for a in SPEC.bleed_areas(c)) for c in (5, 15)]
    runs = np.array([0, 1, 1, 0, 1])
    table = TabulatedDamper(SPEC, settings, runs)  # type: ignore[arg-type]
    assert table.max_error_n < 3.0  # the kinks above 2 m/s; within 2 N + 0.2 % of F
    rng = np.random.default_rng(4)
    for _ in range(50):
        x = rng.uniform(-0.1, 0.1, runs.size)
        v = rng.uniform(-1.5, 1.5, runs.size) * rng.choice([1e-3, 1e-2, 1.0], runs.size)
        a = rng.uniform(-100.0, 100.0, runs.size)
        got = table.force(x, v) + table.added_mass_kg * a + table.force_at_rest_n
        want = [
            damper_force(SPEC, [x[i]], [v[i]], [a[i]], *settings[runs[i]])[0]
            for i in range(runs.size)
        ]
        np.testing.assert_allclose(got, want, atol=1.0)
    # The inertia the car feels is the rod's and gas piston's mass (m_e ≈ 0.45 kg).
    assert table.added_mass_kg == pytest.approx(0.45, rel=0.01)


def test_a_non_separable_model_is_refused() -> None:
    """A term that mixes x and v breaks G(x) + H(v); the table must notice, not guess."""

    class StrokeDependentBleed(Term):
        name = "stroke_dependent_bleed"
        stage = CHAMBER

        def apply(self, w: Work, p: Any, carry: Any, stage: int) -> None:
            w.bleed_compression_m2 = w.bleed_compression_m2 * (1 + 20 * w.x)
            w.bleed_rebound_m2 = w.bleed_rebound_m2 * (1 + 20 * w.x)

    model = DamperModel(SPEC, (StrokeDependentBleed(),))
    area = tuple(float(a) for a in SPEC.bleed_areas(10))
    with pytest.raises(ConfigError, match="separable"):
        TabulatedDamper(model, [area], [0])  # type: ignore[list-item]


def test_step_beyond_rk4_stability_diverges_and_is_reported() -> None:
    limit = stable_step(CAR, 2.0e5)
    n = 2000
    road = synthesize_road(1e-6, 20.0 * n * 4 * limit, seed=1).period_samples(2 * n)
    with pytest.raises(ConfigError, match="diverged"):
        simulate(CAR, LinearDamper(np.array([2.0e5])), road[None, :], 4 * limit, 0)
    ok = simulate(CAR, LinearDamper(np.array([2.0e5])), road[None, :], 0.8 * limit, 0)
    assert np.all(np.isfinite(ok.sprung_accel_m_s2))
