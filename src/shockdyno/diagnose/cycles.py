"""Cycles and phase of each test, and the phase-locked structure of a residual.

Dyno tests are periodic, so a residual splits into what repeats every cycle (the
phase-locked mean: structure, what a model can explain) and what does not (the
cycle-to-cycle scatter at the same phase: noise). Cycles are found from the motion
itself (upward crossings of the mean displacement), so a sine, a slider-crank or any
periodic motion is handled alike; a test with fewer than two whole cycles is one
"cycle" of phase by time.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

N_BINS = 40  # phase bins per cycle: 12-50 ms each at 0.5-1.5 Hz
LONE_K = 10.0  # robust scatters from its bin's median: a lone cell (see `lone_cells`)
LONE_SHARE = 0.02  # of a test's cells at most; more is structure, not a glitch


@dataclass(frozen=True)
class Phase:
    """Per sample: its cycle (-1: outside a whole cycle) and its phase bin."""

    cycle: IntArray
    bin: IntArray
    n_cycles: int


def cycle_starts(t: FloatArray, x: FloatArray) -> FloatArray:
    """Times of upward crossings of the mid-stroke, at least half a period apart."""
    if t.size < 8:
        return np.zeros(0)
    mid = 0.5 * (float(np.max(x)) + float(np.min(x)))
    span = float(np.ptp(x))
    if span <= 0:
        return np.zeros(0)
    # Hysteresis of 10 % of the stroke: sensor noise never makes a false crossing.
    lo, hi = mid - 0.1 * span, mid + 0.1 * span
    state = 0
    out: list[float] = []
    below = x < lo
    above = x > hi
    idx_below = np.flatnonzero(below)
    if idx_below.size == 0:
        return np.zeros(0)
    i = int(idx_below[0])
    n = x.size
    out.extend(_leading_crossing(t, x, mid, hi, i))
    while i < n:
        if state == 0:
            nxt = np.flatnonzero(above[i:])
            if nxt.size == 0:
                break
            j = i + int(nxt[0])
            # the crossing of mid between i and j
            seg = np.flatnonzero(x[i : j + 1] >= mid)
            k = i + int(seg[0]) if seg.size else j
            if k > 0 and x[k] != x[k - 1]:
                frac = (mid - x[k - 1]) / (x[k] - x[k - 1])
                out.append(float(t[k - 1] + frac * (t[k] - t[k - 1])))
            else:
                out.append(float(t[k]))
            state, i = 1, j
        else:
            nxt = np.flatnonzero(below[i:])
            if nxt.size == 0:
                break
            state, i = 0, i + int(nxt[0])
    return np.asarray(out)


def _leading_crossing(
    t: FloatArray, x: FloatArray, mid: float, hi: float, first_below: int
) -> list[float]:
    """The upward crossing a record starts on, which the loop (it starts from the first
    sample below the band) cannot see: a measured window begins where the sine crosses
    its centre going up, so a 3-cycle test showed 2 crossings and was read as one cycle
    (its structure then had no scatter to be judged against: p = 1 on a 25 N stiction).
    When the record rises through the band above mid before it first falls below it, the
    crossing is where the first samples, extended back along their slope, reach mid."""
    rise = np.flatnonzero(x[:first_below] > hi)
    if rise.size == 0 or not x[0] < hi:
        return []
    j = int(rise[0])
    if x[0] < mid:  # inside the record: found by the loop's own rule
        seg = np.flatnonzero(x[: j + 1] >= mid)
        k = int(seg[0])
        return [float(t[k - 1] + (mid - x[k - 1]) / (x[k] - x[k - 1]) * (t[k] - t[k - 1]))]
    slope = (x[j] - x[0]) / max(float(t[j] - t[0]), 1e-12)
    return [float(t[0] - (x[0] - mid) / slope)] if slope > 0 else []


def phase_of(
    t: FloatArray, x: FloatArray, n_bins: int = N_BINS, whole_cells: bool = False
) -> Phase:
    """Each sample's cycle and phase bin. With `whole_cells`, a cell that the record's
    start or end cuts short is left out (cycle -1).

    Why leave them out: a record that starts or ends inside a phase bin holds only part
    of that bin in its first or last cycle. Where the force turns sharply within a bin (a
    seal turning over in the 2-5 ms after a reversal, and a reference-plant test starts
    and ends on one), that part cell's mean differs from the whole cells' by the force's
    shape, not by noise. On a clean reference-plant sweep (seed 708) these cells made the
    cycle-to-cycle scatter of the phase means 16-242 N² per test at 1 kHz, against 1-9 N²
    without them, and the mismatch test could see no structure (p = 1 against 0.001)."""
    starts = cycle_starts(t, x)
    if starts.size < 2:  # no period to read: one "cycle" over the record
        frac = (t - t[0]) / max(float(t[-1] - t[0]), 1e-12)
        b = np.minimum((frac * n_bins).astype(np.intp), n_bins - 1)
        return Phase(np.zeros(t.size, dtype=np.intp), b, 1)
    # The part cycles before the first crossing and after the last are kept, their phase
    # from the median period: with five cycles recorded, that is one more cycle of data.
    period = float(np.median(np.diff(starts)))
    edges = np.concatenate([[starts[0] - period], starts, [starts[-1] + period]])
    # With whole_cells, the cells of a sample one step beyond each end as well: a cell
    # is whole when that sample would leave it.
    extend = whole_cells and t.size >= 2
    step = float(np.median(np.diff(t))) if extend else 0.0
    tt = np.concatenate([[t[0] - step], t, [t[-1] + step]]) if extend else t
    k = np.searchsorted(edges, tt, side="right") - 1
    inside = (k >= 0) & (k < edges.size - 1)
    kk = np.clip(k, 0, edges.size - 2)
    frac = (tt - edges[kk]) / (edges[kk + 1] - edges[kk])
    b = np.minimum((np.clip(frac, 0, 1) * n_bins).astype(np.intp), n_bins - 1)
    cyc = np.where(inside, kk, -1).astype(np.intp)
    if extend:
        for end, beyond in ((1, 0), (t.size, t.size + 1)):
            if cyc[end] >= 0 and k[beyond] == k[end] and b[beyond] == b[end]:
                cyc[(cyc == cyc[end]) & (b == b[end])] = -1
        cyc, b = cyc[1:-1], b[1:-1]
    used = np.unique(cyc[cyc >= 0])
    remap = np.full(edges.size, -1, dtype=np.intp)
    remap[used] = np.arange(used.size)
    cyc = np.where(cyc >= 0, remap[np.maximum(cyc, 0)], -1).astype(np.intp)
    return Phase(cyc, b, int(used.size))


@dataclass(frozen=True)
class BinnedTest:
    """A residual on one test, per (cycle, bin): the structure and the noise.

    `cell[k, b]` is the mean residual of cycle k in bin b (NaN where empty); `mean[b]`
    the phase-locked mean (all samples of the bin over every cycle); `noise_sd_n` the
    per-sample noise (scatter about the mean in each bin); `mean_var[b]` the variance of
    `mean[b]` due to noise.
    """

    cell: FloatArray
    mean: FloatArray
    mean_var: FloatArray
    noise_sd_n: float
    counts: FloatArray  # samples per (cycle, bin)
    lone: int = 0  # cells left out as lone (`lone_cells`)


def lone_cells(cell: FloatArray) -> NDArray[np.bool_]:
    """Cells far from every other cycle's at their phase: one cycle, in a few bins.

    A dyno force can step at a reversal (a closed bleed's click: 1900 N within 2 ms), and
    the diagnosis's grid meets that step in one cycle only when a sample happens to fall
    on it; the residual there is set by where the sample fell, not by noise or the model.
    One such cell (227 N against 2 N of noise, concealed-heat sweep in CI) made its bin's
    scatter the largest term of the noise the mismatch test weighs against, and the heat
    went unseen (p 0.068 against 0.002 on the same sweep recorded again). A cell is lone
    when it lies more than LONE_K robust scatters (its bin's, or the test's if larger)
    from its bin's median, alone in its bin, and such cells are at most LONE_SHARE of the
    test's: what repeats, drifts or spreads over many cells is structure or noise and
    stays."""
    nc = cell.shape[0]
    none = np.zeros(cell.shape, dtype=bool)
    if nc < 4:
        return none
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # bins no cycle reaches
        dev = np.abs(cell - np.nanmedian(cell, axis=0))
        scale = 1.4826 * np.maximum(np.nanmedian(dev, axis=0), np.nanmedian(dev))
    with np.errstate(invalid="ignore"):
        lone = np.isfinite(dev) & (scale > 0) & (dev > LONE_K * scale)
    lone &= np.sum(lone, axis=0) == 1
    if np.sum(lone) > LONE_SHARE * np.sum(np.isfinite(cell)):
        return none
    return np.asarray(lone, dtype=bool)


def _cells(
    r: FloatArray, phase: Phase, ok: NDArray[np.bool_], n_bins: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(samples per cell, sum per cell, cell means) over the samples `ok` marks."""
    nc = phase.n_cycles
    flat = phase.cycle[ok] * n_bins + phase.bin[ok]
    counts = np.bincount(flat, minlength=nc * n_bins).astype(np.float64).reshape(nc, n_bins)
    sums = np.bincount(flat, weights=r[ok], minlength=nc * n_bins).astype(np.float64)
    sums = sums.reshape(nc, n_bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        cell = np.where(counts > 0, sums / counts, np.nan).astype(np.float64)
    return counts, sums, cell


def bin_residual(r: FloatArray, phase: Phase, n_bins: int = N_BINS) -> BinnedTest:
    ok = phase.cycle >= 0
    counts, sums, cell = _cells(r, phase, ok, n_bins)
    lone = lone_cells(cell)
    if np.any(lone):
        ok &= ~lone[np.maximum(phase.cycle, 0), phase.bin]
        counts, sums, cell = _cells(r, phase, ok, n_bins)
    b, v = phase.bin[ok], r[ok]
    total = counts.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(total > 0, sums.sum(axis=0) / total, 0.0)
    dev = v - mean[b]
    dof = max(v.size - n_bins, 1)
    noise_sd = float(np.sqrt(np.sum(dev * dev) / dof))
    # Scatter of the cycle means about the phase mean: the noise of the mean (it keeps
    # the within-bin correlation of the noise, which a per-sample σ²/n would not).
    n_k = np.sum(np.isfinite(cell), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        var_cells = np.nansum((cell - mean) ** 2, axis=0) / np.maximum(n_k - 1, 1)
        mean_var = np.where(n_k > 1, var_cells / n_k, noise_sd**2)
    return BinnedTest(cell, mean, mean_var, noise_sd, counts, int(np.sum(lone)))
