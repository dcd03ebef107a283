"""Isolated spikes on the load cell: a sensor's or its wiring's fault, not physics.

One sample in a hundred read at ten times the force is not a damper: left in, the
diagnosis read it as 674 N of structure and set out to explain it. A lone sample far
outside the test's own force range is taken out (replaced by its neighbours' mean)
before anything is fitted, and the diagnosis says how many and how large, as a sensor
finding. The damper's own sharp features stay inside that range (see `_isolated`); a
spike on a sample near zero force stays inside it too, and barely matters.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter

from shockdyno.record.types import TestData

WINDOW = 5  # samples of the median that sets a test's force range
OUTSIDE_SHARE = 0.2  # a spike lies this share of the range beyond it


@dataclass(frozen=True)
class Spikes:
    count: int  # isolated spikes taken out, all tests
    samples: int  # samples looked at
    tests: int  # tests with any
    largest_n: float  # largest distance of a spike from its neighbours' mean

    def sentence(self) -> str:
        per_k = 1000.0 * self.count / max(self.samples, 1)
        return (
            f"load cell: {self.count} isolated spikes in {self.tests} tests ({per_k:.3g} per "
            f"1000 samples, up to {self.largest_n:.3g} N off their neighbours) were replaced "
            "by their neighbours' mean before the diagnosis: a fault of the sensor or its "
            "wiring to look at, not the damper's physics"
        )


def _isolated(force: NDArray[np.float64]) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Lone samples far outside the test's own force range, and what each sample would
    be from its two neighbours.

    The range is that of the force's five-sample median (which no lone spike moves); a
    spike lies beyond it by a fifth of the range, alone. A damper's own sharp features
    stay inside: a sample at a reversal falls toward the static force between its
    neighbours (a closed bleed's clean sim recordings had 13 single-sample departures of
    up to 644 N, every one inside the range), a breakaway peaks near the force of the
    stroke it starts."""
    between = force.copy()
    between[1:-1] = 0.5 * (force[:-2] + force[2:])
    med = median_filter(force, size=WINDOW, mode="nearest")
    lo, hi = float(np.min(med)), float(np.max(med))
    margin = OUTSIDE_SHARE * (hi - lo)
    out = (force > hi + margin) | (force < lo - margin)
    lone = out.copy()
    lone[1:] &= ~out[:-1]
    lone[:-1] &= ~out[1:]
    lone[0] = lone[-1] = False
    return lone, between


def remove_spikes(tests: Sequence[TestData]) -> tuple[list[TestData], Spikes | None]:
    """The tests with their isolated force spikes replaced, and what was found (None: none)."""
    out: list[TestData] = []
    count = samples = hit = 0
    largest = 0.0
    for t in tests:
        samples += t.force.size
        if t.force.size < 2 * WINDOW:
            out.append(t)
            continue
        lone, between = _isolated(t.force)
        n = int(np.count_nonzero(lone))
        if n == 0:
            out.append(t)
            continue
        count += n
        hit += 1
        largest = max(largest, float(np.max(np.abs(t.force - between)[lone])))
        out.append(replace(t, force=np.where(lone, between, t.force)))
    return out, (Spikes(count, samples, hit, largest) if count else None)
