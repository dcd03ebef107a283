"""A mass between the load cell and the damper that moves with the ram.

Where the load cell sits on the actuator's side, it carries the clevis, the adapter and
the rod eye's bolt between itself and the damper, and reports the force that accelerates
them too: F_cell = F_damper + m ẍ. Dyno software subtracts it as "inertia" or
"acceleration compensation" (MTS's patent US 9,366,692, "Acceleration compensation of
load sensors", corrects exactly this error of a load sensor moving with the test piece);
a cell on the fixed end instead does not feel the rod's own inertia, which the paper's
model counts (`piston_rod_mass_kg`), and m reads negative by up to that mass.

    F = m ẍ          (m: mass_kg; off: 0)

On a sine ẍ = -ω² x: at one frequency the force is a spring's of rate -m ω², so a
sweep at one frequency cannot tell it from the gas spring; across frequencies it grows
with f² where a spring does not. Linear in m, no state.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

from shockdyno.model.composite import FORCE, FloatArray, Term, Work
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading
from shockdyno.model.spec import DamperSpec


class FixtureMass(Term):
    """A mass between the load cell and the damper moving with the ram: the cell reports m·ẍ more
    (a negative m: a cell on the fixed end, which misses the rod's own inertia). A sensor term,
    not carried to a car."""

    name = "fixture_mass"
    stage = FORCE
    sensor = True  # the dyno's hardware, not the damper's: not carried to a car
    summary = "a mass between the load cell and the damper moving with the ram (m·ẍ)"
    follows = ("acceleration",)
    separated_by: ClassVar[dict[str, str]] = {
        "gas_spring": "tests at other frequencies (m·ẍ grows with f², the gas spring does not)",
        "position_force": (
            "tests at other frequencies (m·ẍ grows with f², a force of position does not)"
        ),
        "contact": "tests at other frequencies (m·ẍ grows with f², a bump stop does not)",
    }
    PARAMS = (
        Param(
            "mass_kg",
            "kg",
            nominal=2.0,
            lo=-20.0,
            hi=200.0,
            scale=1.0,
            off=0.0,
            doc="mass moving between the load cell and the damper",
        ),
    )

    def describe(self, r: Reading) -> str:
        """The mass (kg, with σ), and where it sits by its sign."""
        m = r.v("mass_kg")
        where = (
            "between the load cell and the damper, moving with the ram"
            if m >= 0
            else "less than the model counts: the load cell does not feel the rod's own inertia"
        )
        return (
            f"fixture mass: {m:.3g}{r.sd('mass_kg')} kg {where} (its force m·ẍ grows with the "
            "frequency squared; dyno software subtracts it as inertia compensation)"
        )

    def implausible(self, p: Mapping[str, float], spec: DamperSpec) -> str:
        """Refuses a mass more negative than the rod's own (`piston_rod_mass_kg`)."""
        # A cell on the fixed end misses at most the rod's own mass; a larger negative mass
        # is a negative mass, which is something else at the reversals (a lag, a spring).
        if p["mass_kg"] < -spec.piston_rod_mass_kg:
            return (
                f"a moving mass of {p['mass_kg']:.3g} kg is more negative than the rod's own "
                f"{spec.piston_rod_mass_kg:.3g} kg"
            )
        return ""

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        """Add m·ẍ (N) at the FORCE stage; no state."""
        w.add_part(self.name, p["mass_kg"] * w.a)
        return None
