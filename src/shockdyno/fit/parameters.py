"""Everything a calibration fits, by name: one set for the spec's globals, the terms' free
parameters and every click's bleed areas.

Each unknown is optimised as value / scale inside [lo, hi] (bounds in those scaled
units), so the optimiser sees numbers of order one. The set packs a vector for the
optimiser, and unpacks it (and the covariance's σ) back to names; nothing else indexes
into that vector.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

GLOBAL = "global"  # a spec value: "gas_pressure_pa", "rebound_valve.preload_m"
TERM = "term"  # a term's parameter: "friction.breakaway_n"
AREA_BC = "area_bc"  # a click setting's compression bleed area: "A_bc[2]" (group 2)
AREA_BT = "area_bt"  # ... and its rebound bleed area: "A_bt[2]"
KINDS = (GLOBAL, TERM, AREA_BC, AREA_BT)


@dataclass(frozen=True)
class Parameter:
    name: str
    kind: str
    value: float  # the start, in the parameter's own units
    scale: float
    lo: float  # bounds of value / scale
    hi: float


class ParameterSet:
    """Parameters in the optimiser's order: the kinds in KINDS order, each kind's in the
    order given."""

    def __init__(self, items: Sequence[Parameter]) -> None:
        order = {k: i for i, k in enumerate(KINDS)}
        self.items = tuple(sorted(items, key=lambda p: order[p.kind]))  # stable within a kind
        self._spans: dict[str, slice] = {}
        start = 0
        for kind in KINDS:
            n = sum(1 for p in self.items if p.kind == kind)
            self._spans[kind] = slice(start, start + n)
            start += n

    @staticmethod
    def area_name(kind: str, group: int) -> str:
        return f"A_{'bc' if kind == AREA_BC else 'bt'}[{group}]"

    def __len__(self) -> int:
        return len(self.items)

    def span(self, *kinds: str) -> slice:
        """The positions of these kinds (adjacent in KINDS order) in the vector."""
        spans = [self._spans[k] for k in kinds]
        return slice(spans[0].start, spans[-1].stop)

    def of(self, kind: str) -> tuple[Parameter, ...]:
        return self.items[self._spans[kind]]

    def theta0(self) -> FloatArray:
        return np.array([p.value / p.scale for p in self.items], dtype=float)

    def bounds(self) -> tuple[FloatArray, FloatArray]:
        return (
            np.array([p.lo for p in self.items], dtype=float),
            np.array([p.hi for p in self.items], dtype=float),
        )

    def values(self, theta: FloatArray, kind: str) -> dict[str, float]:
        """A kind's values by name, in their own units."""
        return {
            p.name: float(th * p.scale)
            for p, th in zip(self.of(kind), theta[self._spans[kind]], strict=True)
        }

    def vector(self, theta: FloatArray, kind: str) -> FloatArray:
        """A kind's values in order, in their own units (the areas, per group)."""
        scales = np.array([p.scale for p in self.of(kind)], dtype=float)
        return np.asarray(theta[self._spans[kind]] * scales, dtype=float)


def calibration_set(
    globals_start: Mapping[str, tuple[float, float, float, float]],
    terms_start: Mapping[str, tuple[float, float, float, float]],
    a_bc: FloatArray,
    a_bt: FloatArray,
    area_scale: float,
    a_max: float,
) -> ParameterSet:
    """The set a calibration fits: globals and term parameters as name -> (value, scale,
    lo, hi) with lo, hi in scaled units; every group's two areas from 0 to a_max."""
    items = [Parameter(k, GLOBAL, *v) for k, v in globals_start.items()]
    items += [Parameter(k, TERM, *v) for k, v in terms_start.items()]
    for kind, start in ((AREA_BC, a_bc), (AREA_BT, a_bt)):
        items += [
            Parameter(
                ParameterSet.area_name(kind, g), kind, float(a), area_scale, 0.0, a_max / area_scale
            )
            for g, a in enumerate(start)
        ]
    return ParameterSet(items)
