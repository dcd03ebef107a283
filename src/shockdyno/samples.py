"""The samples a DAQ delivers and a recording stores: one type, below both the hardware
(rig/) and the recording format (record/), so that neither depends on the other."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class SampleBlock:
    """Decoded DAQ samples in SI units. Time comes from the DAQ's sequence counter."""

    seq: NDArray[np.int64]  # unwrapped sequence numbers (monotone; gaps are dropped frames)
    t_s: NDArray[np.float64]  # seq / sample_rate_hz
    displacement_m: NDArray[np.float64]  # x > 0 is compression, relative to stroke centre
    force_n: NDArray[np.float64]  # > 0 resists compression
    temperature_c: NDArray[np.float64]
    status: NDArray[np.uint16]

    def __len__(self) -> int:
        return int(self.seq.size)

    @staticmethod
    def empty() -> SampleBlock:
        f = np.zeros(0)
        return SampleBlock(np.zeros(0, np.int64), f, f, f, f, np.zeros(0, np.uint16))

    def frames_missing(self, prev_seq: int | None = None) -> int:
        """Sequence numbers skipped within the block and, given the last one seen before
        it, between that and the block's first."""
        steps = np.diff(self.seq) if prev_seq is None else np.diff(self.seq, prepend=prev_seq)
        return int(np.clip(steps - 1, 0, None).sum())

    def slice(self, lo: int, hi: int) -> SampleBlock:
        """Samples lo to hi (Python slice bounds), as views of these arrays."""
        return SampleBlock(
            self.seq[lo:hi],
            self.t_s[lo:hi],
            self.displacement_m[lo:hi],
            self.force_n[lo:hi],
            self.temperature_c[lo:hi],
            self.status[lo:hi],
        )

    @staticmethod
    def concat(blocks: list[SampleBlock]) -> SampleBlock:
        if not blocks:
            return SampleBlock.empty()
        return SampleBlock(
            np.concatenate([b.seq for b in blocks]),
            np.concatenate([b.t_s for b in blocks]),
            np.concatenate([b.displacement_m for b in blocks]),
            np.concatenate([b.force_n for b in blocks]),
            np.concatenate([b.temperature_c for b in blocks]),
            np.concatenate([b.status for b in blocks]),
        )
