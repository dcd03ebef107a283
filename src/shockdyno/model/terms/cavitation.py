"""Rebound-chamber cavitation: the chamber behind the piston cannot fall below the oil's
vapour / air-release pressure, and what it could not fill must refill first.

In a monotube the compression chamber sits at gas pressure p_c, so on a fast
compression stroke the rebound chamber, p_r = p_c - Δp, is the one that would go below
p_v once Δp exceeds p_c - p_v. It cannot: it sits at p_v, the compression force
saturates (earlier at lower gas pressure), and vapour fills the volume the flow does not.
After reversal the vapour must be pushed back before the chamber's pressure builds, so
the rebound force lags (model/chamber.py integrates both, with the compressibility
term's compliance when it is in the model). Off: p_v = -∞ (no floor). A recording that
never reaches p_v bounds it only from above.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from shockdyno.model.chamber import Chamber
from shockdyno.model.composite import PRESSURE, Evaluation, FloatArray, Term, Work
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading
from shockdyno.model.terms.compressibility import run_chamber


class Cavitation(Term):
    name = "cavitation"
    stage = PRESSURE + 5  # after compressibility: the floor acts on the chamber it found
    stateful = True
    summary = "rebound chamber floored at the vapour / air-release pressure; vapour refills"
    PARAMS = (
        Param(
            "release_pressure_pa",
            "Pa",
            nominal=3000.0,
            lo=-5.0e6,  # below any pressure the data reach: the floor never acts (nests "off")
            hi=1.0e6,
            scale=1.0e5,
            off=-math.inf,
            doc="absolute pressure the rebound chamber cannot fall below",
        ),
    )

    def describe(self, r: Reading) -> str:
        floor = r.v("release_pressure_pa")
        if not math.isfinite(floor):
            return "cavitation: no floor (off)"
        if floor >= 0:
            return (
                f"cavitation: the rebound chamber holds at {floor / 1e3:.3g} kPa absolute; "
                "compression force saturates"
            )
        # No chamber holds below vacuum: the saturation is real, but the model's chamber
        # pressure runs low by at least this much (the gas charge, or how the pressure
        # splits across the piston), so the floor's value is not a release pressure.
        return (
            "cavitation: compression force saturates as if the rebound chamber held at "
            f"{floor / 1e3:.3g} kPa absolute, below vacuum: the model's chamber pressure "
            f"runs at least {-floor / 1e3:.3g} kPa low there, so this is not the release "
            "pressure"
        )

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        # Below the lowest pressure the data reach the floor does nothing (no gradient),
        # and a little above it the floor already moves the force by hundreds of N: the
        # band where it binds but does not overshoot is narrow. So the starts sit just
        # above the lowest rebound-chamber pressure the model without it reaches.
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
        found = w.chamber if isinstance(w.chamber, Chamber) else None
        chamber = Chamber(
            air_fraction=found.air_fraction if found else 0.0,
            charge_pa=w.spec.gas_pressure_pa,
            oil_compressibility_per_pa=found.oil_compressibility_per_pa if found else 0.0,
            release_pa=floor,
            length_m=w.spec.oil_column_m,
        )
        dp, vapour, state, p_c = run_chamber(w, chamber, carry)
        w.set_p_c(self.name, p_c)
        w.set_dp(self.name, dp)
        w.outputs[f"{self.name}.vapour_m3"] = vapour
        return state
