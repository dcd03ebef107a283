"""Sweeps with a known answer, made from the model the way the simulated rig makes them.

The true rod motion is the commanded sine, lagged and rippled a little by the servo
(tracking error); the true force is the model's at that motion with the true bleed areas.
The "measured" channels add what a rig adds: LVDT noise and quantisation on x, load-cell
noise and quantisation on F. Velocity and acceleration of the truth are analytic, so the
fit sees only what the rig would give it: the noisy, quantised x and F.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from shockdyno.model import damper_force
from shockdyno.model.spec import DamperSpec
from shockdyno.record.types import TestData, TestMeta

FloatArray = NDArray[np.float64]


# A "real" damper for known-truth checks: its globals depart from the nominal spec the fit
# starts from by 10-30 % (tests and benchmarks fit sweeps made with these).
PERTURBED_GLOBALS: dict[str, float] = {
    "gas_pressure_pa": 1.45e6,
    "friction_n": 45.0,
    "compression_valve.preload_m": 1.3e-4,
    "compression_valve.face_area_m2": 2.3e-4,
    "rebound_valve.preload_m": 1.8e-4,
    "rebound_valve.face_area_m2": 1.45e-4,
}


def _motion(
    t: FloatArray, amp: float, w: float, lag: float, ripple: float, wr: float, phase: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The rod's true x, v, a: the commanded sine, lagged, plus the servo's ripple."""
    arg, rip = w * (t - lag), wr * t + phase
    x = amp * np.sin(arg) + ripple * np.sin(rip)
    v = amp * w * np.cos(arg) + ripple * wr * np.cos(rip)
    a = -amp * w**2 * np.sin(arg) - ripple * wr**2 * np.sin(rip)
    return x, v, a


def synthetic_sweep(
    spec: DamperSpec,
    clicks: Sequence[int],
    frequencies_hz: Sequence[float] = (0.5, 1.0, 1.5),
    *,
    cycles: int = 2,
    amplitude_m: float = 0.03,
    sample_rate_hz: float = 1000.0,
    gas_clicks: int = 0,
    areas: dict[int, tuple[float, float]] | None = None,
    lvdt_noise_m: float = 3e-6,
    lvdt_lsb_m: float = 1e-6,
    load_noise_n: float = 3.0,
    load_lsb_n: float = 0.5,
    tracking_lag_s: float = 0.002,
    ripple_m: float = 5e-5,
    ripple_hz: float = 9.0,
    temperature_c: float | None = None,
    force_delay_s: float = 0.0,
    seed: int = 0,
) -> list[TestData]:
    """One test per (click, frequency), measured cycles only.

    `areas` maps a click to the true (A_bc, A_bt); by default `spec.bleed_areas`.
    `force_delay_s` makes the force channel lag the displacement channel by that much.
    """
    rng = np.random.default_rng(seed)
    tests: list[TestData] = []
    for c in clicks:
        if areas is not None and c in areas:
            a_bc, a_bt = areas[c]
        else:
            bc, bt = spec.bleed_areas(c, gas_clicks)
            a_bc, a_bt = float(bc), float(bt)
        for f in frequencies_hz:
            n = round(cycles / f * sample_rate_hz) + 1
            t = np.arange(n) / sample_rate_hz
            w, wr = 2 * np.pi * f, 2 * np.pi * ripple_hz
            phase = rng.uniform(0, 2 * np.pi)
            shape = (amplitude_m, w, tracking_lag_s, ripple_m, wr, phase)
            x, _, _ = _motion(t, *shape)
            xd, vd, ad = _motion(t - force_delay_s, *shape)
            force = damper_force(spec, xd, vd, ad, a_bc, a_bt)
            x_meas = x + rng.normal(0, lvdt_noise_m, n)
            f_meas = force + rng.normal(0, load_noise_n, n)
            if lvdt_lsb_m > 0:
                x_meas = np.round(x_meas / lvdt_lsb_m) * lvdt_lsb_m
            if load_lsb_n > 0:
                f_meas = np.round(f_meas / load_lsb_n) * load_lsb_n
            temp = None
            if temperature_c is not None:
                temp = temperature_c + rng.normal(0, 0.05, n)
            meta = TestMeta(
                index=len(tests),
                clicks=int(c),
                gas_clicks=gas_clicks,
                frequency_hz=float(f),
                amplitude_m=amplitude_m,
                sample_rate_hz=sample_rate_hz,
                measured_cycles=cycles,
            )
            tests.append(TestData(meta=meta, t=t, x=x_meas, force=f_meas, temperature=temp))
    return tests
