"""Damper model evaluation rate: vectorised solve vs a per-sample brentq implementation.

Both evaluate the same equations on the same 30 s, 1 kHz, 30 mm / 1.5 Hz test with LVDT
noise. The baseline is how one would first write eq. 1-7: a Python loop over samples
with scipy.optimize.brentq for each pressure drop. It is timed on a slice and its rate
extrapolated (it is too slow to run on all 30 000 samples in a benchmark); its forces on
that slice must agree with the vectorised model's.
Aim (issue 2): >= 1 M samples/s and >= 100x the baseline.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.optimize import brentq

from shockdyno.model import damper_force, differentiate, load_spec
from shockdyno.model.damper import ATMOSPHERE_PA


def per_sample_force(spec, x, v, a, a_bc, a_bt):  # type: ignore[no-untyped-def]
    out = np.empty_like(x)
    cd, rho = spec.discharge_coefficient, spec.oil_density_kg_m3
    v0 = spec.gas_piston_area_m2 * spec.gas_length_m
    for i in range(x.size):
        q = (spec.annulus_area_m2 - spec.couette_area_m2) * v[i]
        if q > 0:
            valve, a_b = spec.compression_valve, a_bc
        else:
            valve, a_b = spec.rebound_valve, a_bt
        k = valve.stiffness_n_per_m

        def residual(dp: float, a_b=a_b, valve=valve, k=k, q=q) -> float:
            lift = min(max((dp * valve.face_area_m2 - valve.preload_n) / k, 0.0), valve.max_lift_m)
            area = a_b + valve.perimeter_m * lift
            return cd * area * math.sqrt(2 * dp / rho) + spec.leak_conductance_m3_s_pa * dp - abs(q)

        dp = 0.0 if q == 0 else brentq(residual, 0.0, 1e9, xtol=1e-9, rtol=1e-12)
        dp = dp if q > 0 else -dp
        p_g = spec.gas_pressure_pa * v0 / (v0 - spec.rod_area_m2 * x[i])
        p_c = p_g + spec.rod_area_m2 * spec.gas_piston_mass_kg / spec.gas_piston_area_m2**2 * a[i]
        out[i] = (
            spec.piston_rod_mass_kg * a[i]
            + (p_c - ATMOSPHERE_PA) * spec.rod_area_m2
            + dp * spec.annulus_area_m2
            + spec.friction_n * math.tanh(v[i] / spec.friction_velocity_m_s)
        )
    return out


def main() -> None:
    spec = load_spec()
    rng = np.random.default_rng(0)
    t = np.arange(0, 30, 1e-3)
    x = 0.03 * np.sin(2 * math.pi * 1.5 * t) + rng.normal(0, 5e-6, t.size)
    v, a = differentiate(t, x)
    a_bc, a_bt = (float(z) for z in spec.bleed_areas(10))

    damper_force(spec, x, v, a, a_bc, a_bt)  # warm caches
    reps = 20
    t0 = time.perf_counter()
    for _ in range(reps):
        f = damper_force(spec, x, v, a, a_bc, a_bt)
    fast = reps * x.size / (time.perf_counter() - t0)

    n = 2000
    sl = slice(5000, 5000 + n)
    t0 = time.perf_counter()
    f_ref = per_sample_force(spec, x[sl], v[sl], a[sl], a_bc, a_bt)
    slow = n / (time.perf_counter() - t0)
    worst = float(np.max(np.abs(f_ref - f[sl])))
    ms = x.size / fast * 1e3
    print(f"vectorised model:        {fast:12,.0f} samples/s (30 s at 1 kHz in {ms:.1f} ms)")
    print(f"per-sample brentq:       {slow:12,.0f} samples/s (baseline, {n} samples)")
    print(f"ratio:                   {fast / slow:12,.0f} x")
    print(f"max force difference:    {worst:12.2e} N (same equations, both solves converged)")
    print(
        f"aims: >= 1,000,000 samples/s: {'met' if fast >= 1e6 else 'NOT met'}; "
        f">= 100x: {'met' if fast / slow >= 100 else 'NOT met'}"
    )


if __name__ == "__main__":
    main()
