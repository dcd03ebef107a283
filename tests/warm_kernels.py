"""Compile the project's numba kernels once, into their on-disk caches, before the test
workers start (`make test` runs it beside mypy). On a fresh clone each of the workers
otherwise compiled the same kernels at once in its first tests, on cores the other
workers needed. Each kernel is reached through the code that uses it: the damper model
with every library term on (and a seal with presliding), the load-cell filter, and the
reference plant, the plant in a process of its own beside the model's (a third of the
compiling, and `make test` gives mypy the other core for part of it only)."""

from __future__ import annotations

import multiprocessing

import numpy as np

from shockdyno.model.composite import DamperModel, ModelInputs
from shockdyno.model.filters import biquad
from shockdyno.model.spec import load_spec
from shockdyno.model.terms import LIBRARY, make_term
from shockdyno.simrig.reference import PlantParams, reference_sweep

ON = {  # values that switch each term on where its nominal is off
    "sensor_lag.delay_s": 0.004,
    "sensor_lag.load_cell_lag_s": 0.003,
    "gas_spring.volume_factor": 0.5,
    "position_force.f7_n": 300.0,
    "cavitation.release_pressure_pa": 1.2e6,
    "thermal.heat_rate_k_s_m2": 100.0,
}


def sine(n: int, f: float, fs: float) -> ModelInputs:
    t = np.arange(n) / fs
    w = 2 * np.pi * f
    x = 0.03 * np.sin(w * t)
    return ModelInputs.single(x, 0.03 * w * np.cos(w * t), -w * w * x, 1 / fs)


def plant() -> None:
    spec = load_spec()
    params = PlantParams(
        breakaway_n=30.0, air_fraction=0.01, oil_bulk_modulus_pa=1.6e9, bump_onset_m=0.02,
        bump_force_at_10mm_n=500.0, viscosity_at_100c_cst=10.0, lip_drag_n=5.0,
    )  # fmt: skip
    reference_sweep(spec, params, [2], (1.5,), cycles=1, warmup_cycles=0, rest_s=0.1)


def main() -> None:
    beside = multiprocessing.get_context("spawn").Process(target=plant)
    beside.start()
    spec = load_spec()
    bc, bt = (float(a) for a in spec.bleed_areas(8, 0))
    two = ModelInputs.stack([sine(2000, 1.0, 1000.0), sine(600, 0.5, 300.0)])
    seal = spec.with_values({"friction_presliding_m": 1e-4})
    for inputs in (two, sine(3000, 1.5, 1000.0)):
        for terms in [tuple(make_term(n) for n in sorted(LIBRARY))] + [
            (make_term(n),) for n in sorted(LIBRARY)
        ]:
            model = DamperModel(spec, terms)
            on = {k: v for k, v in ON.items() if k in dict(model.param_list())}
            model.with_values(on).force(inputs, bc, bt)
        DamperModel(seal, (make_term("friction"),)).force(inputs, bc, bt)
    biquad(np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), np.zeros(8), np.zeros(2))
    beside.join()
    if beside.exitcode != 0:
        raise SystemExit(
            f"the reference plant's kernels failed to compile (exit {beside.exitcode})"
        )


if __name__ == "__main__":
    main()
