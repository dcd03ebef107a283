"""Shared rig data types and the small device contracts the sweep runner depends on."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

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


@runtime_checkable
class Daq(Protocol):
    sample_rate_hz: float

    def read(self) -> SampleBlock:
        """Every complete, valid sample waiting now (possibly none); never blocks long."""
        ...

    @property
    def dropped_frames(self) -> int: ...

    @property
    def corrupt_frames(self) -> int: ...

    def close(self) -> None: ...


@runtime_checkable
class Adjuster(Protocol):
    def set_clicks(self, rod_clicks: int, gas_clicks: int) -> None:
        """Set the damper's adjusters (a motor, or an operator prompt that waits)."""

    def set_adjusters(self, setting: Mapping[str, int], gas_clicks: int) -> None:
        """Set each named adjuster of a damper with several (a register
        `NAME_clicks` each, or a prompt), and the gas bottle."""
        ...
