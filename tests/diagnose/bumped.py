"""A synthetic sweep with a bump stop added to its force, fitted without one: the start
of the contact candidate's tests."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.candidates import binned_means
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.diagnose.stats import noise_draws
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec


@dataclass(frozen=True)
class Bumped:
    data: Data
    base: Fitted  # the damper fitted without the stop
    means: NDArray[np.float64]
    noise: NDArray[np.float64]


def bumped(onset_m: float, force_n: float, seed: int = 8) -> Bumped:
    """Clicks 5 and 15, 3 cycles, with F (depth/10 mm)² past `onset_m` added."""
    spec = load_spec(None)
    tests = []
    for t in synthetic_sweep(spec, [5, 15], cycles=3, seed=seed):
        bump = force_n * (np.maximum(t.x - onset_m, 0.0) / 0.01) ** 2
        tests.append(replace(t, force=t.force + bump))
    prepared, _ = prepare_tests(tests)
    data = Data.build(spec, prepared)
    base = refit(data, DamperModel(spec), (), None, max_nfev=30)
    means, binned = binned_means(data, base.residual)
    return Bumped(data, base, means, noise_draws(binned, np.random.default_rng(0), 99))
