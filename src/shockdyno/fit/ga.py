"""The paper's genetic algorithm (Table 1), as MATLAB's `ga` runs it, seeded.

Table 1: two variables in [0, 1], initial population and population size 50, stochastic
uniform selection, scattered crossover, Gaussian mutation, 150 generations. What the
table leaves to MATLAB's defaults is taken from them: rank fitness scaling
(expectation ∝ 1/√rank), elite count ceil(0.05 × 50) = 3, crossover fraction 0.8, and
Gaussian mutation with scale 1 and shrink 1, whose standard deviation shrinks as
σ_k = σ_{k-1} (1 - k / generations) from the width of the range. Mutants are clipped
into [0, 1].

Several independent problems (one per click) run in lockstep, and a generation's new
individuals are scored together: one (large) model call per generation.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
# (individuals, problems, n_vars) in [0, 1] -> (individuals, problems) objectives
Fitness = Callable[[FloatArray], FloatArray]


@dataclass(frozen=True)
class GaSettings:
    population: int = 50
    generations: int = 150
    elite_fraction: float = 0.05
    crossover_fraction: float = 0.8
    mutation_scale: float = 1.0
    mutation_shrink: float = 1.0


@dataclass
class GaResult:
    best: FloatArray  # (problems, n_vars)
    score: FloatArray  # (problems,)
    history: list[FloatArray] = field(default_factory=list)  # best score per generation


def _stochastic_uniform(
    expectation: FloatArray, n_parents: int, rng: np.random.Generator
) -> NDArray[np.intp]:
    """Parents picked by equally spaced pointers over the cumulative expectation."""
    edges = np.cumsum(expectation)
    edges = edges / edges[-1] * n_parents
    pointers = rng.uniform(0, 1) + np.arange(n_parents)
    return np.minimum(np.searchsorted(edges, pointers, side="right"), expectation.size - 1)


def run_ga(
    fitness: Fitness,
    n_problems: int,
    n_vars: int,
    rng: np.random.Generator,
    settings: GaSettings = GaSettings(),
    on_generation: Callable[[int, FloatArray], None] | None = None,
) -> GaResult:
    s = settings
    pop_n = s.population
    n_elite = math.ceil(s.elite_fraction * pop_n)
    n_children = pop_n - n_elite
    n_xover = round(s.crossover_fraction * n_children)
    n_mut = n_children - n_xover
    pop = rng.uniform(0, 1, size=(pop_n, n_problems, n_vars))
    scores = fitness(pop)  # (pop, problems)
    sigma = s.mutation_scale * 1.0  # the range of the variables is 1
    ranks_weight = 1.0 / np.sqrt(np.arange(1, pop_n + 1))
    history: list[FloatArray] = []
    for gen in range(1, s.generations + 1):
        order = np.argsort(scores, axis=0, kind="stable")  # (pop, problems)
        new = np.empty_like(pop)
        cols = np.arange(n_problems)
        new[:n_elite] = pop[order[:n_elite], cols]
        for j in range(n_problems):
            expectation = np.empty(pop_n)
            expectation[order[:, j]] = ranks_weight
            parents = _stochastic_uniform(expectation, 2 * n_xover + n_mut, rng)
            rng.shuffle(parents)
            p1 = pop[parents[:n_xover], j]
            p2 = pop[parents[n_xover : 2 * n_xover], j]
            mask = rng.uniform(0, 1, size=p1.shape) < 0.5
            new[n_elite : n_elite + n_xover, j] = np.where(mask, p1, p2)
            pm = pop[parents[2 * n_xover :], j]
            mutant = pm + rng.normal(0, 1, size=pm.shape) * sigma
            new[n_elite + n_xover :, j] = np.clip(mutant, 0.0, 1.0)
        sigma *= max(1.0 - s.mutation_shrink * gen / s.generations, 0.0)
        pop = new
        scores[:n_elite] = scores[order[:n_elite], cols]
        scores[n_elite:] = fitness(pop[n_elite:])
        history.append(scores.min(axis=0))
        if on_generation is not None:
            on_generation(gen, history[-1])
    best_i = np.argmin(scores, axis=0)
    cols = np.arange(n_problems)
    return GaResult(best=pop[best_i, cols], score=scores[best_i, cols], history=history)
