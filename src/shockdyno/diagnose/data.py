"""The tests under diagnosis: stacked for the model, with each test's cycles and phase."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.cycles import N_BINS, BinnedTest, Phase, bin_residual, phase_of
from shockdyno.fit.prepare import PreparedTest
from shockdyno.fit.problem import StackedProblem
from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


@dataclass
class Data:
    """Prepared tests, their stacked problem, and per test its slice and phase."""

    prepared: list[PreparedTest]
    prob: StackedProblem
    slices: list[slice]
    phases: list[Phase]
    full_rate_hz: float | None = None

    @staticmethod
    def build(
        spec: DamperSpec, prepared: Sequence[PreparedTest], full_rate_hz: float | None = None
    ) -> Data:
        prob = StackedProblem(spec, prepared, full_rate_hz)
        slices, phases, lo = [], [], 0
        for p in prepared:
            n = p.obj.size
            slices.append(slice(lo, lo + n))
            ph = phase_of(p.data.t[p.obj], p.data.x[p.obj], whole_cells=True)
            phases.append(leave_out(ph, step_at_turn(p.v, p.data.force, p.obj)))
            lo += n
        return Data(list(prepared), prob, slices, phases, full_rate_hz)

    @property
    def n_tests(self) -> int:
        return len(self.prepared)

    def binned(self, residual: FloatArray) -> list[BinnedTest]:
        return [
            bin_residual(residual[s], ph) for s, ph in zip(self.slices, self.phases, strict=True)
        ]

    def bin_matrix(self, columns: FloatArray) -> FloatArray:
        """Phase-bin means of per-sample columns (samples × k) → (tests·bins × k)."""
        cols = columns.reshape(columns.shape[0], -1)
        out = np.zeros((self.n_tests * N_BINS, cols.shape[1]))
        for i, (s, ph) in enumerate(zip(self.slices, self.phases, strict=True)):
            ok = ph.cycle >= 0
            b = ph.bin[ok]
            counts = np.bincount(b, minlength=N_BINS).astype(float)
            block = cols[s][ok]
            for j in range(cols.shape[1]):
                sums = np.bincount(b, weights=block[:, j], minlength=N_BINS)
                with np.errstate(invalid="ignore", divide="ignore"):
                    out[i * N_BINS : (i + 1) * N_BINS, j] = np.where(counts > 0, sums / counts, 0.0)
        return out

    def subset(self, keep: Sequence[int]) -> Data:
        return Data.build(self.prob.base, [self.prepared[i] for i in keep], self.full_rate_hz)


def step_at_turn(v: FloatArray, f: FloatArray, idx: IntArray) -> NDArray[np.bool_]:
    """Which samples `idx` sit on a force step the converter did not resolve at a turn.

    The turn lies within a sample interval of the sample (the velocity's sign differs
    between its two neighbours), and the force changed more across those two intervals
    than across the two beside them on either side: the step (a closed bleed's valve
    preloads, over a kN) happened within the sample's own interval. Such a sample reads
    whatever share of each side the converter averaged, set by where the turn fell in the
    interval; no model evaluated at the sample's instant says that value. Where the load
    cell resolves the turn over several samples (an anti-alias filter before it, a seal
    that turns over its presliding travel), the force changes as much beside the sample,
    and the sample is evidence of how it turns: it stays."""
    n = v.size
    if n < 7:
        return np.zeros(idx.size, dtype=bool)

    def at(k: IntArray) -> IntArray:
        return np.asarray(np.clip(k, 0, n - 1), dtype=np.intp)

    turn = (v[at(idx - 1)] * v[at(idx + 1)] <= 0) | (v[idx] == 0)
    across = np.abs(f[at(idx + 1)] - f[at(idx - 1)])
    before = np.abs(f[at(idx - 1)] - f[at(idx - 3)])
    after = np.abs(f[at(idx + 3)] - f[at(idx + 1)])
    inside = (idx >= 3) & (idx <= n - 4)
    return np.asarray(turn & inside & (across > np.maximum(before, after)), dtype=bool)


def leave_out(ph: Phase, out: NDArray[np.bool_]) -> Phase:
    """The phase with the samples `out` in no cycle: no cell, mean or scatter holds them."""
    if not np.any(out):
        return ph
    return replace(ph, cycle=np.where(out, -1, ph.cycle).astype(np.intp))


def time_halves(p: PreparedTest) -> tuple[PreparedTest, PreparedTest] | None:
    """The test's first and second halves in time (whole cycles), for a held-out check
    on a single test; None when it has fewer than four cycles."""
    t = p.data.t
    ph = phase_of(t, p.data.x)
    if ph.n_cycles < 4:
        return None
    k = ph.cycle
    half = ph.n_cycles // 2
    first = np.flatnonzero((k >= 0) & (k < half))
    second = np.flatnonzero(k >= half)
    out = []
    for idx in (first, second):
        lo, hi = int(idx[0]), int(idx[-1]) + 1
        d = p.data
        temp = None if d.temperature is None else d.temperature[lo:hi]
        part = replace(d, t=d.t[lo:hi], x=d.x[lo:hi], force=d.force[lo:hi], temperature=temp)
        obj = (p.obj[(p.obj >= lo) & (p.obj < hi)] - lo).astype(np.intp)
        out.append(PreparedTest(part, p.v[lo:hi], p.a[lo:hi], obj))
    return out[0], out[1]
