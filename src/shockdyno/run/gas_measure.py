"""The static gas force, measured on the rig at mid-stroke as commercial dynos do.

The ram comes to rest at mid-stroke (x = 0) twice: once arriving from the extended side,
moving in compression, and once arriving from the compressed side, moving in rebound; at
each rest the force is averaged over a dwell (after the servo settles). The gas force is
the mean of the two.

Why at rest, not while moving slowly through x = 0: at a few mm/s an open bleed's damping is
small and odd in velocity, so the mean of a compression and a rebound pass cancels it to
first order; but with the bleed closed (click 0 of the simulated damper) the valves' preload
carries the force even at 1 mm/s (+790 N compression, -1056 N rebound: a mean of -133 N
against a gas force of 231 N). At rest the damping is gone whatever the clicks; what is
left of the approach (friction, oil trapped behind a closed valve) has opposite signs after
the two approaches and cancels in their mean. Half their difference is reported as the
hysteresis at rest, the size of that correction.

Pressure trapped behind closed valves does not cancel: with the bleed shut and aerated oil
(sim/scenarios/aerated-oil.toml at click 0) the rests read +643 N and -504 N, whose mean
(70 N) is no gas force. Rests more than MAX_HYSTERESIS_N apart from their mean (far more
than the seal friction of a race damper, 35-60 N) are reported and not used: the tests of
that click take the last good measurement of the same gas setting (the gas force does not
depend on rod clicks), or none, and the report then takes another click's.

When: at the start of the sweep and after every click change. The gas force depends on the
charge and its temperature (the oil warms through a sweep), not on the rod clicks; measuring
at each click change follows the warm-up for one short hold per click.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from shockdyno.errors import RigFault
from shockdyno.samples import SampleBlock

OFFSET_M = 0.005  # the approach: from 5 mm either side of mid-stroke
VELOCITY_M_S = 0.004  # at 4 mm/s
DWELL_S = 0.6  # at rest this long (DAQ time) each time
START_DWELL_S = 0.05  # a pause before the approach, so it starts from rest
SETTLE_S = 0.15  # the first part of the dwell is the servo settling: not averaged
MIN_SAMPLES = 50
REST_TOLERANCE_M = 50e-6  # still: within this of the final position (LVDT noise ~1-10 µm)
MAX_HYSTERESIS_N = 100.0  # half the difference of the two rests, beyond which it is not gas


class Holder(Protocol):
    """What the gas-force measurement needs of a session: move to an offset and hold still."""

    def hold_at(
        self,
        offset_m: float,
        velocity_m_s: float | None,
        dwell_s: float,
        on_block: Callable[[SampleBlock], None],
    ) -> tuple[float, float]:
        """Move at `velocity_m_s` (None: the rig's move velocity) to `offset_m` from the stroke
        centre (+ compression), hold still for `dwell_s` of DAQ time, every sample to `on_block`;
        returns the DAQ times (s) of arriving and of the hold's end."""


@dataclass(frozen=True)
class GasMeasurement:
    """The static gas force at mid-stroke (N, positive pushing the rod out: resisting
    compression): the mean of the forces at rest after arriving in compression and in rebound,
    and the DAQ time (s) it ended."""

    force_n: float  # the static gas force at mid-stroke: the mean of the two rests
    after_compression_n: float  # at rest after arriving in compression
    after_rebound_n: float  # at rest after arriving in rebound
    t_s: float  # DAQ time at the end of the measurement

    @property
    def hysteresis_n(self) -> float:
        """Half the difference of the two rests (N): friction and trapped oil, which their mean
        cancels."""
        return (self.after_compression_n - self.after_rebound_n) / 2

    @property
    def usable(self) -> bool:
        """Whether the rests agree within MAX_HYSTERESIS_N, so their mean is a gas force."""
        return abs(self.hysteresis_n) <= MAX_HYSTERESIS_N

    def message(self) -> str:
        """One line for the log and the recording's events: the force, both rests, and why it is
        not used where it is not."""
        text = (
            f"static gas force {self.force_n:.1f} N at mid-stroke (at rest after compression "
            f"{self.after_compression_n:.1f} N, after rebound {self.after_rebound_n:.1f} N)"
        )
        if not self.usable:
            text += (
                f": not used, the rests differ by more than 2 x {MAX_HYSTERESIS_N:g} N "
                "(pressure trapped behind closed valves?)"
            )
        return text


def rest_force(blocks: list[SampleBlock], start_s: float, end_s: float) -> float:
    """Mean force of the samples in [start_s, end_s] once the ram is still: after the last
    sample more than REST_TOLERANCE_M from where it ends, plus SETTLE_S (the samples, not
    the drive's word, say when it stopped: near an instant after, a shut bleed's force at a
    fraction of a mm/s is hundreds of N)."""
    run = SampleBlock.concat(blocks) if blocks else SampleBlock.empty()
    if len(run):
        x_end = float(np.median(run.displacement_m[-MIN_SAMPLES:]))
        away = np.flatnonzero(np.abs(run.displacement_m - x_end) > REST_TOLERANCE_M)
        if away.size:
            start_s = max(start_s, float(run.t_s[away[-1]]) + SETTLE_S)
    keep = (run.t_s >= start_s) & (run.t_s <= end_s) & np.isfinite(run.force_n)
    if np.count_nonzero(keep) < MIN_SAMPLES:
        raise RigFault(
            f"gas force: only {np.count_nonzero(keep)} samples at rest at mid-stroke "
            f"(need {MIN_SAMPLES})"
        )
    return float(np.mean(run.force_n[keep]))


def measure_gas_force(
    session: Holder,
    on_block: Callable[[SampleBlock], None] | None = None,
    *,
    offset_m: float = OFFSET_M,
    velocity_m_s: float = VELOCITY_M_S,
    dwell_s: float = DWELL_S,
) -> GasMeasurement:
    """Approach mid-stroke in compression, rest; in rebound, rest (module docstring).

    Every sample also goes to `on_block` (the recording, outside any test)."""
    forces: list[float] = []
    t_end = math.nan
    for side in (-1.0, 1.0):  # from the extended side (compression), then the compressed
        # To the start at the rig's move velocity; only the approach itself is slow.
        session.hold_at(side * offset_m, None, START_DWELL_S, _sink(on_block, []))
        blocks: list[SampleBlock] = []
        arrived, t_end = session.hold_at(0.0, velocity_m_s, dwell_s, _sink(on_block, blocks))
        forces.append(rest_force(blocks, arrived + min(SETTLE_S, dwell_s / 2), t_end))
    comp, reb = forces
    return GasMeasurement((comp + reb) / 2, comp, reb, t_end)


def _sink(
    on_block: Callable[[SampleBlock], None] | None, keep: list[SampleBlock]
) -> Callable[[SampleBlock], None]:
    def sink(block: SampleBlock) -> None:
        keep.append(block)
        if on_block is not None:
            on_block(block)

    return sink
