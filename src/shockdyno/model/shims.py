"""Shim-stack valve: stiffness from annular-plate theory and the opening it gives.

Each shim is a thin annular plate clamped at its inner (clamp) radius and free at its
outer radius, loaded by the oil as a ring load at the outer edge. For an axisymmetric
plate with no distributed load the deflection is

    w(r) = C1 + C2 r² + C3 ln r + C4 r² ln r,

and equilibrium of the shear force fixes C4 = P / (8 π D) with D = E t³ / (12 (1 - ν²)).
The clamp gives w(b) = w'(b) = 0 and the free edge M_r(a) = 0; solving that 3×3 system
gives the edge deflection w(a) and so k = P / w(a). Shims of one diameter stacked without
friction share the load and add their stiffnesses, so a stack of n is n times one shim
(an upper estimate: real stacks with tapered shims are softer, which the fit absorbs into
the calibrated stiffness).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import Annotated

import numpy as np
from msgspec import Meta

from shockdyno.schema import NonNegative, Positive


@dataclass(frozen=True)
class ShimStack:
    """One direction's valve: the shim stack, its seat and its preload."""

    n_shims: Annotated[int, Meta(ge=1)]
    thickness_m: Positive
    outer_diameter_m: Positive
    clamp_diameter_m: Positive
    seat_diameter_m: Positive  # where the stack lifts off the piston land: the flow perimeter
    face_area_m2: Positive  # piston-port area the pressure acts over, pushing the stack open
    preload_m: NonNegative  # dish of the piston face: the stack is pre-bent by this much
    max_lift_m: Positive  # travel stop (backing shim / spacer)
    youngs_modulus_pa: Positive = 206e9
    poisson: Annotated[float, Meta(ge=0, lt=0.5)] = 0.3

    @cached_property  # a 3×3 solve; the flow solve asks for it at every evaluation
    def stiffness_n_per_m(self) -> float:
        """The stack's stiffness at its outer edge (N/m): n shims times one annular plate's."""
        return self.n_shims * annular_plate_edge_stiffness(
            self.thickness_m,
            self.outer_diameter_m / 2,
            self.clamp_diameter_m / 2,
            self.youngs_modulus_pa,
            self.poisson,
        )

    @property
    def preload_n(self) -> float:
        """The force (N) the dished face pre-bends the stack with: stiffness × preload_m."""
        return self.stiffness_n_per_m * self.preload_m

    @property
    def perimeter_m(self) -> float:
        """The flow perimeter where the stack lifts off its seat, π × seat diameter (m)."""
        return math.pi * self.seat_diameter_m

    @property
    def crack_pressure_pa(self) -> float:
        """The pressure drop (Pa) at which the stack starts to lift: preload over face area."""
        return self.preload_n / self.face_area_m2


# A fit that frees a valve's preload or face area makes a new ShimStack at every model
# evaluation (so its cached stiffness is lost) with the same plate: 32 000 solves in one
# diagnosis. The result is a pure function of five floats; equal floats here are the same
# floats (only ±0 compare equal with other bits, and a zero thickness, modulus or radius
# raises for either sign while ν's sign drops out of the arithmetic), so a cached value is
# the one a solve would give. typed: an int argument is kept apart from its float.
@lru_cache(maxsize=256, typed=True)
def annular_plate_edge_stiffness(
    thickness_m: float, outer_radius_m: float, clamp_radius_m: float, e_pa: float, nu: float
) -> float:
    """Ring load at the free outer edge over the deflection there, N/m (one plate)."""
    a, b = outer_radius_m, clamp_radius_m
    if not 0 < b < a:
        raise ValueError("clamp radius must lie between 0 and the outer radius")
    d = e_pa * thickness_m**3 / (12 * (1 - nu**2))
    p = 1.0  # unit load: the system is linear
    c4 = p / (8 * math.pi * d)
    lb, la = math.log(b), math.log(a)
    # Unknowns C1, C2, C3. Rows: w(b) = 0, w'(b) = 0, M_r(a) = 0 (M_r ∝ w'' + ν w'/r).
    m = np.array(
        [
            [1.0, b**2, lb],
            [0.0, 2 * b, 1 / b],
            [0.0, 2 * (1 + nu), -(1 - nu) / a**2],
        ]
    )
    rhs = -c4 * np.array(
        [
            b**2 * lb,
            2 * b * lb + b,
            (2 * la + 3) + nu * (2 * la + 1),
        ]
    )
    c1, c2, c3 = np.linalg.solve(m, rhs)
    w_a = c1 + c2 * a**2 + c3 * la + c4 * a**2 * la
    return p / abs(float(w_a))
