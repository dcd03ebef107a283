"""Benchmark: the ride study's 60-run grid (3 clicks × 5 roads × 4 speeds) against
scipy.integrate.solve_ivp on the same quarter car and damper, measured in this run.

    .venv/bin/python benchmarks/bench_ride.py

The study integrates all 60 runs at once (fixed-step RK4 on state arrays, damper from
per-click tables). The baselines integrate one run at a time with solve_ivp (RK45,
rtol 1e-6, atol 1e-9; the road under the tyre from a periodic cubic spline of the same
samples): (a) with the same damper table, (b) with the full damper model called at
every right-hand-side evaluation. Baselines run a sample of runs over a shorter span and
are scaled to the grid by simulated seconds (stated in the output), to stay well within
the 90 s budget; their RMS is compared with the study's on the same run and span.
"""

from __future__ import annotations

import sys
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from shockdyno.fit.result import FitResult
from shockdyno.model import damper_force, default_spec_path
from shockdyno.model.quarter_car import (
    QuarterCar,
    TabulatedDamper,
    linear_steady_state,
    simulate,
)
from shockdyno.model.road import class_psd, synthesize_road
from shockdyno.ride.study import RideConfig, run_study

SPAN_S, WARMUP_S, DT = 8.0, 2.0, 1e-3
START_C = 6000.0  # N·s/m: the linear car whose steady state starts every integrator
SAMPLE = [(5, "A", 20.0), (10, "C", 80.0), (15, "E", 120.0)]


def ivp_run(
    car: QuarterCar,
    force: object,
    added_mass: float,
    road: np.ndarray,
    period_s: float,
    y0: np.ndarray,
    warmup_s: float = WARMUP_S,
) -> tuple[float, np.ndarray, int]:
    """One run with solve_ivp; returns wall time, sprung acceleration at t_k, RHS calls."""
    n_half = road.size
    t_grid = np.arange(n_half + 1) * period_s / n_half
    spline = CubicSpline(t_grid, np.append(road, road[0]), bc_type="periodic")
    ms, mu = car.sprung_mass_kg + added_mass, car.unsprung_mass_kg + added_mass
    det = ms * mu - added_mass**2
    ks, kt = car.spring_n_m, car.tyre_n_m
    f = force  # callable (x, v) -> F on length-1 arrays
    calls = 0

    def accel(t: float, y: np.ndarray) -> tuple[float, float]:
        x, v = y[2] - y[0], y[3] - y[1]
        p = ks * x + float(f(np.array([x]), np.array([v]))[0])  # type: ignore[operator]
        q = kt * (float(spline(t % period_s)) - y[2]) - p
        return (mu * p + added_mass * q) / det, (added_mass * p + ms * q) / det

    def rhs(t: float, y: np.ndarray) -> list[float]:
        nonlocal calls
        calls += 1
        a_s, a_u = accel(t, y)
        return [y[1], a_s, y[3], a_u]

    t0 = time.perf_counter()
    sol = solve_ivp(rhs, (-warmup_s, period_s), y0, rtol=1e-6, atol=1e-9, dense_output=True)
    wall = time.perf_counter() - t0
    tk = np.arange(round(period_s / DT)) * DT
    ys = sol.sol(tk)
    acc = np.array([accel(t, ys[:, i])[0] for i, t in enumerate(tk)])
    return wall, acc, calls


def main() -> int:
    fit = FitResult.from_spec(default_spec_path(), (5, 10, 15))
    spec = fit.spec()
    car = QuarterCar()

    config = RideConfig(step_check=False)
    t0 = time.perf_counter()
    res = run_study(config, fit)
    grid_wall = time.perf_counter() - t0
    sim_seconds = len(res.runs) * (config.duration_s + config.warmup_s)
    print(
        f"study grid: {len(res.runs)} runs x {config.duration_s + config.warmup_s:g} s "
        f"(incl. {config.warmup_s:g} s warm-up) at dt = {config.dt_s * 1e3:g} ms: "
        f"{grid_wall:.2f} s wall  ({grid_wall / sim_seconds * 1e3:.3f} ms per simulated s)"
    )
    t0 = time.perf_counter()
    run_study(RideConfig(), fit)
    print(f"study grid with its dt/2 step check: {time.perf_counter() - t0:.2f} s wall")

    # Same runs, shorter span, for the baselines and for a like-for-like accuracy check.
    areas = [fit.areas(c) for c in (5, 10, 15)]
    n = round(SPAN_S / DT)
    roads, rows = [], []
    for c, r, v in SAMPLE:
        prof = synthesize_road(class_psd(r), v / 3.6 * SPAN_S, config.band_rad_m, 2.0, 0)
        roads.append(prof.period_samples(2 * n))
        rows.append((5, 10, 15).index(c))
    table = TabulatedDamper(spec, areas, rows)
    # Every integrator starts from the same state: the study's (a linear car's steady state).
    road_arr = np.array(roads)
    start = (-2 * round(WARMUP_S / DT)) % road_arr.shape[1]
    y0 = linear_steady_state(car, START_C, road_arr.T, DT / 2, start)
    ours = simulate(car, table, road_arr, DT, round(WARMUP_S / DT), START_C)

    span_total = SPAN_S + WARMUP_S
    wall_tab, wall_full = [], []
    for k, (c, r, v) in enumerate(SAMPLE):
        one = table.for_runs([rows[k]])
        wall, acc, calls = ivp_run(car, one.force, table.added_mass_kg, roads[k], SPAN_S, y0[:, k])
        rms_ivp = float(np.sqrt(np.mean(acc**2)))
        rms_ours = float(np.sqrt(np.mean(ours.sprung_accel_m_s2[k] ** 2)))
        wall_tab.append(wall)
        print(
            f"solve_ivp RK45, table damper, {c} clicks road {r} {v:g} km/h, {span_total:g} s: "
            f"{wall:.2f} s wall, {calls} RHS calls; RMS {rms_ivp:.4f} vs study's RK4 "
            f"{rms_ours:.4f} m/s² ({abs(rms_ivp / rms_ours - 1) * 100:.3f} % apart)"
        )
    a_bc, a_bt = areas[0]
    f0 = float(damper_force(spec, [0.0], [0.0], [0.0], a_bc, a_bt)[0])

    def full_model(x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return damper_force(spec, x, v, 0.0 * x, a_bc, a_bt) - f0

    short = 2.0
    n_short = round(short / DT)
    prof = synthesize_road(class_psd("A"), 20 / 3.6 * short, config.band_rad_m, 2.0, 0)
    # The full model's inertia enters through added_mass like the table's.
    r_short = prof.period_samples(2 * n_short)
    y0_short = linear_steady_state(car, START_C, r_short[:, None], DT / 2, -1000 % r_short.size)
    wall, _, calls = ivp_run(
        car, full_model, table.added_mass_kg, r_short, short, y0_short[:, 0], 0.5
    )
    wall_full.append(wall / (short + 0.5))
    print(
        f"solve_ivp RK45, full damper model, 5 clicks road A 20 km/h, {short + 0.5:g} s: "
        f"{wall:.2f} s wall, {calls} RHS calls"
    )

    per_sim_s_tab = sum(wall_tab) / (len(SAMPLE) * span_total)
    est_tab = per_sim_s_tab * sim_seconds
    est_full = wall_full[0] * sim_seconds
    print(
        f"baseline (a) solve_ivp + same table, scaled to the grid's {sim_seconds:g} "
        f"simulated s: {est_tab:.0f} s  -> study is {est_tab / grid_wall:.0f}x faster"
    )
    print(
        f"baseline (b) solve_ivp + full model per call (road A 20 km/h, the easiest run), "
        f"scaled: {est_full:.0f} s  -> study is {est_full / grid_wall:.0f}x faster (a lower "
        "bound: rougher roads need more steps)"
    )
    print(f"aim < 10 s for the grid: {'met' if grid_wall < 10 else 'NOT met'} ({grid_wall:.2f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
