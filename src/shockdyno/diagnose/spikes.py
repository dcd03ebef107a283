"""Isolated spikes on the load cell: a sensor's or its wiring's fault, not physics.

One sample in a hundred read at ten times the force is not a damper: left in, the
diagnosis read it as 674 N of structure and set out to explain it. A lone sample far
from its two neighbours is taken out (replaced by their mean) before anything is
fitted, and the diagnosis says how many, where and how large, as a sensor finding. A real
step (a closed bleed's force at reversal moves in one sample) is kept: see `_isolated`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from shockdyno.record.types import TestData

WINDOW = 5  # fewer samples than this in a test: not looked at
DOMINANCE = 1.5  # a spike's departure over its neighbours' (2 for a spike, 1 for a step)
SIGMAS = 8.0  # a spike stands this many noise-σ (robust, of the high-passed force) off
# ... and this share of the test's force range: a quantised load cell's MAD understates
# its noise (a synthetic sweep's 14 N tails stood 8σ off), and a wiring spike is large.
MIN_SHARE = 0.05


@dataclass(frozen=True)
class Spikes:
    count: int  # isolated spikes taken out, all tests
    samples: int  # samples looked at
    tests: int  # tests with any
    largest_n: float  # largest distance of a spike from its neighbours' median

    def sentence(self) -> str:
        per_k = 1000.0 * self.count / max(self.samples, 1)
        return (
            f"load cell: {self.count} isolated spikes in {self.tests} tests ({per_k:.3g} per "
            f"1000 samples, up to {self.largest_n:.3g} N off their neighbours) were replaced "
            "by their neighbours' mean before the diagnosis: a fault of the sensor or its "
            "wiring to look at, not the damper's physics"
        )


def _isolated(force: NDArray[np.float64]) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Lone spikes, and what each sample would be from its two neighbours.

    e_i = f_i - (f_{i-1} + f_{i+1}) / 2 is about 0 on a smooth force, however steep (120 N a
    sample at 1.5 Hz). A lone spike s reads (-s/2, s, -s/2) in e; a step h between two
    samples reads (-h/2, +h/2): a spike's e stands at twice its neighbours', a step's equals
    its neighbour's, so a real step (a closed bleed at reversal) is kept."""
    between = force.copy()
    between[1:-1] = 0.5 * (force[:-2] + force[2:])
    e = force - between
    e[0] = e[-1] = 0.0
    a = np.abs(e)
    sigma = 1.4826 * float(np.median(np.abs(e[1:-1] - np.median(e[1:-1]))))
    threshold = max(SIGMAS * sigma, MIN_SHARE * float(np.ptp(between)), 1e-9)
    beside = np.maximum(np.r_[0.0, a[:-1]], np.r_[a[1:], 0.0])
    return (a > threshold) & (a > DOMINANCE * beside), between


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
        lone, med = _isolated(t.force)
        n = int(np.count_nonzero(lone))
        if n == 0:
            out.append(t)
            continue
        count += n
        hit += 1
        largest = max(largest, float(np.max(np.abs(t.force - med)[lone])))
        out.append(replace(t, force=np.where(lone, med, t.force)))
    return out, (Spikes(count, samples, hit, largest) if count else None)
