"""Bleed-orifice area as a function of the adjuster clicks.

The needle closes the orifice at 0 clicks and backs out of it as clicks increase; each
click opens less than the one before (the paper's Fig. 12: the change is largest in the
first few clicks and negligible past about 15). A saturating exponential has that shape:

    A(n) = A_closed + (A_open - A_closed) · (1 - exp(-n/τ)) / (1 - exp(-N/τ)),

with N the last click. It is monotone in n for any τ > 0; a large τ makes it nearly
linear, like the paper's rebound area (eq. 10). The gas-bottle selector adds a fixed
area per click to the rebound path (the paper: the rebound stroke is governed mainly by
the gas-bottle selector).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
from msgspec import Meta
from numpy.typing import ArrayLike, NDArray

from shockdyno.schema import NonNegative, Positive


@dataclass(frozen=True)
class BleedLaw:
    """One bleed path's area law (a [bleed.*] table of the spec): the area (m²) from
    `area_closed_m2` at 0 clicks to `area_open_m2` at `max_clicks`, saturating over
    `shape_clicks` (module doc), plus `area_per_gas_click_m2` for each gas-bottle click."""

    area_closed_m2: NonNegative
    area_open_m2: NonNegative
    shape_clicks: Positive
    max_clicks: Annotated[int, Meta(ge=1)] = 21
    area_per_gas_click_m2: float = 0.0  # either sign: a gas click may open or close the bleed

    def area(self, clicks: ArrayLike, gas_clicks: ArrayLike = 0) -> NDArray[np.float64]:
        """The bleed area (m²) at rod-adjuster `clicks` and gas-bottle `gas_clicks` (counted open
        from 0 = closed), element by element."""
        n = np.asarray(clicks, dtype=float)
        g = np.asarray(gas_clicks, dtype=float)
        tau = self.shape_clicks
        frac = -np.expm1(-n / tau) / -np.expm1(-self.max_clicks / tau)
        base = self.area_closed_m2 + (self.area_open_m2 - self.area_closed_m2) * frac
        return np.asarray(base + self.area_per_gas_click_m2 * g, dtype=float)


PATHS = ("compression", "rebound")  # the flow paths an adjuster may act on


@dataclass(frozen=True)
class Adjuster:
    """One adjuster of a damper with several ([adjuster.NAME] in the spec): the bleed path
    it acts on. Its area law is that path's (DamperSpec.compression_bleed or
    rebound_bleed), written in the adjuster's own table, so a fitted or changed law stays
    in one place. A damper whose spec declares none has the paper's one rod needle,
    acting on both bleeds ([bleed.*])."""

    name: str
    acts_on: Literal["compression", "rebound"]
