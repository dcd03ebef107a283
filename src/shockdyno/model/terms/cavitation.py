"""Rebound-chamber cavitation: the chamber behind the piston cannot fall below the oil's
vapour / air-release pressure.

In a monotube the compression chamber sits at gas pressure p_c, so on a fast
compression stroke the rebound chamber, p_r = p_c - Δp, is the one that would go below
p_v once Δp exceeds p_c - p_v. It cannot: p_r = max(p_c - Δp, p_v), Δp = p_c - p_r, and
the compression force saturates (earlier at lower gas pressure). Off: p_v = -∞ (no
clamp). A recording that never reaches p_v bounds it only from above.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from shockdyno.model.composite import PRESSURE, Evaluation, FloatArray, Term, Work
from shockdyno.model.params import Param


class Cavitation(Term):
    name = "cavitation"
    stage = PRESSURE + 5  # after compressibility: the clamp acts on the chamber's pressure
    summary = "rebound chamber clamped at the vapour / air-release pressure"
    PARAMS = (
        Param(
            "release_pressure_pa",
            "Pa",
            3000.0,
            -5.0e6,  # below any pressure the data reach: the clamp never acts (nests "off")
            1.0e6,
            1.0e5,
            -math.inf,
            doc="absolute pressure the rebound chamber cannot fall below",
        ),
    )

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        # Below the lowest pressure the data reach the clamp does nothing (no gradient),
        # and a little above it the clamp already moves the force by hundreds of N: the
        # band where it binds but does not overshoot is narrow (7e5 Pa did nothing and
        # 9e5 overshot on a sweep whose truth was 8.5e5). So the starts sit just above
        # the lowest rebound-chamber pressure the model without the clamp reaches.
        fixed = [3e3, 1e5, 3e5, 5e5, 7e5, 9e5]
        if seen is not None and seen.p_c.size:
            lowest = float(np.min(seen.p_c - seen.dp))
            span = float(np.median(seen.p_c)) - lowest
            if math.isfinite(lowest) and span > 0:
                fixed += [lowest + q * span for q in (0.01, 0.03, 0.06, 0.1, 0.2, 0.35)]
        hi = self.PARAMS[0].hi
        return [{"release_pressure_pa": p} for p in sorted({min(p, hi) for p in fixed})]

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        floor = p["release_pressure_pa"]
        if floor == -math.inf:
            return None
        assert w.dp is not None
        p_r = np.maximum(w.p_c - w.dp, floor)
        w.set_dp(self.name, w.p_c - p_r)
        return None
