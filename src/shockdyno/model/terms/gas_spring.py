"""The gas spring the spec assumed may be wrong: polytropic index and gas volume.

The paper's eq. 5 is isothermal with the spec's gas volume V0: p = p0 V0 / (V0 - A x).
This term makes it p = p0 (V / (V - A x))^n with V = f V0. Off: n = 1, f = 1. Over a
±30 mm stroke the force is nearly linear in x, so the data pin the spring rate
p0 n A² / V, not n and V apart: the fit frees f and holds n unless asked
(`--terms gas_spring.polytropic_index`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from shockdyno.model.composite import CHAMBER, Evaluation, FloatArray, Term, Work
from shockdyno.model.params import Param, SpecCalibration
from shockdyno.model.reading import Reading


class GasSpring(Term):
    """The gas spring corrected: the gas volume as a factor on the spec's, and a polytropic index
    n, p = p0·(V/(V - A·x))^n, in place of eq. 5's isothermal gas."""

    name = "gas_spring"
    stage = CHAMBER
    summary = "gas spring rate: polytropic index and gas volume"
    follows = ("displacement",)
    separated_by: ClassVar[dict[str, str]] = {
        "position_force": "a test at another gas pressure",
        "contact": (
            "a test at another gas pressure (the gas spring scales with the charge, a bump "
            "stop does not)"
        ),
        "thermal": "a test held at constant temperature",
    }
    # A ±30 mm stroke pins the rate p0·n·A²/V, not n and V apart, so the gas volume
    # carries it at the spec's (isothermal) index. A spec's gas volume is a guess within a
    # factor of two; a rate that needs more than that is something else acting over the
    # stroke (a bump stop, a top-out spring) and is left to the diagnosis's search.
    calibrates = SpecCalibration(
        "volume_factor",
        "gas_volume_m3",
        "m³",
        within=(0.5, 2.0),
        quantity="gas volume",
        effect="the gas spring rate",
    )
    PARAMS = (
        Param(
            "volume_factor",
            "1",
            nominal=1.0,
            lo=0.2,
            hi=5.0,
            scale=1.0,
            off=1.0,
            doc="gas volume / the spec's",
        ),
        Param(
            "polytropic_index", "1", nominal=1.0, lo=1.0, hi=1.67, scale=0.1, off=1.0, free=False
        ),
    )

    def describe(self, r: Reading) -> str:
        """The gas volume as a factor on the spec's (with σ) and the polytropic index."""
        return (
            f"gas spring: gas volume {r.v('volume_factor'):.3g}{r.sd('volume_factor')} × the "
            f"spec's (polytropic index {r.v('polytropic_index'):.3g})"
        )

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        """Gas volumes of 0.5, 1 and 2 times the spec's."""
        return [{"volume_factor": f} for f in (0.5, 1.0, 2.0)]

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        """Rescale the compression chamber's gas pressure (CHAMBER stage; the gas-piston inertia
        kept) and leave the gas column and index for the chamber terms; no state."""
        spec = w.spec
        v0 = spec.gas_volume_m3
        swept = spec.rod_area_m2 * w.x
        vol = p["volume_factor"] * v0
        base = v0 / np.maximum(v0 - swept, 1e-3 * v0)
        new = (vol / np.maximum(vol - swept, 1e-3 * vol)) ** p["polytropic_index"]
        inertia = spec.rod_area_m2 * spec.gas_piston_mass_kg / spec.gas_piston_area_m2**2 * w.a
        gas = w.p_c - inertia
        w.set_p_c(self.name, inertia + gas * (new / base))
        w.gas_volume = np.maximum(vol - swept, 1e-3 * vol)
        w.gas_index = p["polytropic_index"]
        return None
