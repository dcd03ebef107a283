"""What a recording holds, independent of the file format."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

# The motions whose measured cycles follow warm-up cycles of the same motion (a sine, or a
# constant-velocity stroke: model/stroke.py), unlike an imported test's arbitrary motion.
PERIODIC_MOTIONS = ("sine", "triangle", "trapezoid")


@dataclass(frozen=True)
class TestMeta:
    """One dyno test: one click setting at one frequency."""

    __test__ = False  # not a pytest test class, despite the name

    index: int
    clicks: int
    gas_clicks: int
    frequency_hz: float
    amplitude_m: float
    sample_rate_hz: float
    warmup_cycles: int = 0
    measured_cycles: int = 0
    motion: str = "sine"  # "sine", or "imported" for arbitrary motion from another dyno
    # Start and end time (s, on the recording's time base) of the measured cycles:
    measured_start_s: float | None = None
    measured_end_s: float | None = None
    # "complete" | "aborted" (stopped early: safety, Ctrl-C, fault) | "degraded" (ran to the
    # end, but its measured motion missed the plan or it lost too many frames: not complete);
    # "running" in a test's begin record; "interrupted" as read back when no end followed
    # (the process died mid-test). docs/safety.md.
    status: str = "complete"
    extra: dict[str, str] = field(default_factory=dict)
    # Optional, added with the MCAP recording (older code need not set them):
    cycle_start_s: tuple[float, ...] = ()  # start of each cycle (warm-up and measured), s
    dropped_frames: int | None = None  # frames lost between DAQ and host (seq gaps if not given)
    corrupt_frames: int | None = None  # frames that failed their check (known only to the DAQ)
    gas_pressure_pa: float | None = None  # measured gas charge (absolute), when known
    abort_reason: str | None = None  # why a test stopped early (status "aborted")
    start_temperature_c: float | None = None  # oil temperature when the test began
    # Static gas force on the rod at mid-stroke (N) and where it came from: "measured" (the
    # sweep's hold at mid-stroke, run/gas_measure.py) or "estimated" (report/gas.py, from
    # the sine's reversals); None when unknown. Older recordings have neither.
    gas_force_n: float | None = None
    gas_force_source: str | None = None
    # A constant-velocity test (motion "triangle" or "trapezoid", model/stroke.py): the
    # speed planned between reversals and a trapezoid's reversal acceleration. None for a
    # sine; older recordings have neither (and every test of theirs is a sine).
    target_velocity_m_s: float | None = None
    reversal_accel_m_s2: float | None = None
    # Every adjuster's clicks, by name, for a damper with several (docs/adjusters.md);
    # empty (and not written) for the one rod adjuster, whose clicks are `clicks`.
    adjusters: dict[str, int] = field(default_factory=dict)

    @property
    def setting(self) -> tuple[tuple[str, int], ...]:
        """The adjusters' clicks sorted by name: () for the one rod adjuster."""
        return tuple(sorted(self.adjusters.items()))


@dataclass(frozen=True)
class TestData:
    """One test as analysis reads it: its metadata, time `t` (s), displacement `x` (m from the
    stroke centre, compression positive), `force` (N, positive resisting compression) and
    `temperature` (°C, or None)."""

    __test__ = False  # not a pytest test class, despite the name

    meta: TestMeta
    t: NDArray[np.float64]
    x: NDArray[np.float64]
    force: NDArray[np.float64]
    temperature: NDArray[np.float64] | None = None

    def measured(self) -> TestData:
        """Only the measured cycles (the whole record when no window is recorded)."""
        lo, hi = self.meta.measured_start_s, self.meta.measured_end_s
        if lo is None or hi is None:
            return self
        keep = (self.t >= lo) & (self.t <= hi)
        temp = None if self.temperature is None else self.temperature[keep]
        return replace(
            self, t=self.t[keep], x=self.x[keep], force=self.force[keep], temperature=temp
        )
