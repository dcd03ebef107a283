"""The DAQ read as the session's clock and eyes.

Each read brings the latest sample's DAQ time (the time base of everything the session
does), position, temperature and motion bit, streams the block to a sink (the recording),
and, when checking, trips on a limit on any sample, a run of lost frames long enough to
have left the limits unwatched, or a stream that has gone quiet.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from shockdyno.errors import RigFault
from shockdyno.rig.config import DaqConfig, Limits
from shockdyno.rig.frames import STATUS_MOTION
from shockdyno.rig.types import Daq
from shockdyno.run.safety import LimitMonitor, SafetyEvent, SafetyTrip
from shockdyno.samples import SampleBlock

BlockSink = Callable[[SampleBlock], None]


class DaqStream:
    """The DAQ as the session's clock: each read updates the DAQ time (s), the displacement (m
    from the stroke centre, compression positive), temperature (°C) and motion bit of the latest
    sample, checks the limits on every sample, and hands the block to the recording."""

    def __init__(self, cfg: DaqConfig, limits: Limits, clock: Callable[[], float]) -> None:
        self.cfg = cfg
        self.clock = clock
        self.monitor = LimitMonitor(limits)
        self.t = 0.0  # DAQ time of the latest sample
        self.temp = math.nan
        self.x = math.nan  # displacement at the latest sample (m from the stroke centre)
        self.motion = False  # the motion output at the latest sample
        self.seq: int | None = None  # sequence number of the latest sample
        self.last_sample_wall = clock()
        self.fresh = False  # the latest read brought samples: the DAQ clock is current
        self.on_block: BlockSink | None = None

    def read(self, daq: Callable[[], Daq], check: bool) -> SampleBlock:
        """Read the DAQ once: update the clock, check limits, stream the block."""
        try:
            block = daq().read()
        except RigFault as exc:
            if check:
                raise SafetyTrip(SafetyEvent(self.t, "link_lost", str(exc))) from None
            time.sleep(0.005)  # stopping: the drive's own status is enough
            block = SampleBlock.empty()
        now = self.clock()
        self.fresh = bool(len(block))
        if len(block):
            self.last_sample_wall = now
            gap = self._largest_gap(block)
            self.t = float(block.t_s[-1])
            self.temp = float(block.temperature_c[-1])
            self.x = float(block.displacement_m[-1])
            self.motion = bool(block.status[-1] & STATUS_MOTION)
            if self.on_block is not None:
                self.on_block(block)
            if check:
                ev = self.monitor.check(block)
                if ev is not None:
                    raise SafetyTrip(ev)
                if gap is not None:
                    raise SafetyTrip(gap)
        elif check and now - self.last_sample_wall > self.cfg.frozen_timeout_s:
            raise SafetyTrip(
                SafetyEvent(
                    self.t,
                    "daq_frozen",
                    f"DAQ frozen: no valid frame for {now - self.last_sample_wall:.2f} s",
                )
            )
        return block

    def _largest_gap(self, block: SampleBlock) -> SafetyEvent | None:
        """A run of lost frames longer than daq.max_gap_s: limits went unwatched."""
        prev = self.seq
        self.seq = int(block.seq[-1])
        steps = np.diff(block.seq, prepend=block.seq[0] if prev is None else prev)
        i = int(np.argmax(steps))
        lost = int(steps[i]) - 1
        if lost <= self.cfg.max_gap_s * self.cfg.sample_rate_hz:
            return None
        return SafetyEvent(
            float(block.t_s[i]),
            "daq_gap",
            f"DAQ gap: {lost} frames lost in a row "
            f"(limit {self.cfg.max_gap_s * 1e3:g} ms of samples)",
        )
