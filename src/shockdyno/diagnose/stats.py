"""Tests that respect how few independent values a correlated residual holds.

A dyno residual at 1 kHz has tens of thousands of samples but, being smooth and periodic,
only a few hundred independent values: a per-sample F-test or AIC would call almost any
extra parameter significant. Here every statistic works on the phase-locked means (one
value per phase bin per test), and its reference distribution comes from resampling
whole cycles of the cycle-to-cycle scatter, which keeps the noise's correlation within
a cycle (a wild cycle bootstrap: each whole cycle of scatter with a random sign).

- `mismatch_test`: is there structure beyond noise? S = Σ mean² over bins and tests,
  against the same sum for phase means built from resampled noise cycles.
- `lr_bootstrap`: does a term improve the fit more than noise would let any such term?
  The statistic is the drop in Σ mean² from the baseline refit to the refit with the
  term (both refitted jointly with globals and areas). Its null distribution is a
  parametric bootstrap: data = the baseline model + resampled noise cycles, refitted by
  both models linearised at the term's fit (Jacobian in the binned space; all the
  term's parameters move, so the search over a nuisance such as a Stribeck velocity or
  a delay is part of the reference, not only the amplitude). The two-sided linear
  refit lets a term's amplitude go either way, so the p-value is conservative where an
  amplitude is bounded at its off value.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.cycles import BinnedTest

AT_BOUND = 1e-3  # of a parameter's scale: a fitted value this near a range's end sits at it


def at_bound(value: float, bound: float, scale: float) -> bool:
    """Whether a fitted value sits at `bound`: within a thousandth of its `scale`. A bound's
    σ is no error bar, so none enters; a value that is not finite sits at no bound."""
    return abs(value - bound) <= AT_BOUND * scale


FloatArray = NDArray[np.float64]
N_BOOT = 999


def noise_draws(binned: Sequence[BinnedTest], rng: np.random.Generator, n: int) -> FloatArray:
    """n bootstrap phase means of pure noise: (tests·bins × n)."""
    out = []
    for bt in binned:
        cells = bt.cell
        nb = cells.shape[1]
        dev = np.where(np.isfinite(cells), cells - bt.mean, 0.0)
        k = dev.shape[0]
        if k < 2:
            # One cycle: no scatter to resample; noise of a mean from its variance.
            out.append(rng.standard_normal((nb, n)) * np.sqrt(bt.mean_var)[:, None])
            continue
        # Each whole cycle's scatter with a random sign (a wild cluster bootstrap: under
        # the null the scatter is symmetric, and a cycle keeps its correlation); unlike
        # drawing cycles with replacement it never repeats one extreme cycle k times.
        # A bin's mean is over the cycles that reach it (the part cycles at a test's ends
        # reach some bins only), so each bin scales by its own count: dividing by every
        # cycle made the noise of a bin the part cycles miss 40 % too small in variance
        # (4 of 5 cycles), and the tests too ready to call a mismatch significant.
        signs = rng.choice([-1.0, 1.0], size=(n, k))
        n_k = np.sum(np.isfinite(cells), axis=0).astype(float)
        with np.errstate(invalid="ignore", divide="ignore"):
            scale = np.where(n_k > 1, np.sqrt(n_k / np.maximum(n_k - 1, 1)) / n_k, 0.0)
        draws = (signs @ dev) * scale  # (n, nb)
        few = n_k < 2
        if np.any(few):  # one cycle in the bin: the noise of its mean from its variance
            draws[:, few] = rng.standard_normal((n, int(np.sum(few)))) * np.sqrt(bt.mean_var[few])
        out.append(draws.T)
    return np.vstack(out)


@dataclass(frozen=True)
class MismatchStat:
    p_value: float
    structure_energy: float  # Σ mean² - Σ noise var of the mean (N²·bins)
    noise_floor_n: float  # per-sample noise, pooled over tests
    structured_rms_n: float
    structured_share: float  # of the residual's mean square that repeats every cycle
    effective_values: float  # independent values the binned residual holds
    lone_cells: int = 0  # (cycle, bin) cells left out as a lone sample's (cycles.lone_cells)


def mismatch_test(
    binned: Sequence[BinnedTest], rng: np.random.Generator, n_boot: int = N_BOOT
) -> MismatchStat:
    means = np.concatenate([b.mean for b in binned])
    s_obs = float(np.sum(means**2))
    draws = noise_draws(binned, rng, n_boot)
    s_null = np.sum(draws**2, axis=0)
    p = (1 + int(np.sum(s_null >= s_obs))) / (n_boot + 1)
    var_mean = np.concatenate([b.mean_var for b in binned])
    energy = max(s_obs - float(np.sum(var_mean)), 0.0)
    noise = float(np.sqrt(np.mean([b.noise_sd_n**2 for b in binned])))
    structured_rms = float(np.sqrt(energy / max(means.size, 1)))
    total_ms = structured_rms**2 + noise**2
    share = structured_rms**2 / total_ms if total_ms > 0 else 0.0
    lone = sum(b.lone for b in binned)
    return MismatchStat(p, energy, noise, structured_rms, share, effective_values(binned), lone)


def effective_values(binned: Sequence[BinnedTest]) -> float:
    """Independent values in the phase means: bins over (1 + 2 Σ lag correlation)."""
    total = 0.0
    for b in binned:
        m = b.mean - np.mean(b.mean)
        denom = float(np.sum(m * m))
        tau = 1.0
        if denom > 0:
            for k in range(1, m.size // 2):
                rho = float(np.sum(m[k:] * m[:-k]) + np.sum(m[:k] * m[-k:])) / denom
                if rho < 0.05:
                    break
                tau += 2 * rho
        total += m.size / tau
    return total


def basis(j: FloatArray, rtol: float = 1e-9) -> FloatArray:
    """Orthonormal basis of the column space (rank-revealing, scale-free): directions whose
    singular value of the unit-scaled columns exceeds `rtol` of the largest."""
    norms = np.linalg.norm(j, axis=0)
    cols = j[:, norms > 0] / norms[norms > 0]
    if cols.shape[1] == 0:
        return np.zeros((j.shape[0], 0))
    u, s, _ = np.linalg.svd(cols, full_matrices=False)
    keep = s > rtol * s[0]
    return np.asarray(u[:, keep], dtype=float)


def lr_bootstrap(
    lr_obs: float,
    jac_null: FloatArray,
    jac_alt: FloatArray,
    noise: FloatArray,
) -> float:
    """p-value of an observed drop in Σ mean² against linearised refits of noise draws."""
    q0, q1 = basis(jac_null), basis(jac_alt)
    lr = np.sum((q1.T @ noise) ** 2, axis=0) - np.sum((q0.T @ noise) ** 2, axis=0)
    return float((1 + int(np.sum(lr >= lr_obs))) / (noise.shape[1] + 1))
