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

from shockdyno.model.spec import DamperSpec

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
    unit: str = ""


@dataclass(frozen=True)
class SpecGlobal:
    """A spec value the calibration may move (named as DamperSpec.value names it), within
    factors of the spec's own value; `fallback` is its scale where the spec gives 0.
    `starts`: other values (SI) a search tries before it calibrates one whose error has
    more than one basin (diagnose/candidates.calibration_start)."""

    name: str
    unit: str
    lo_factor: float
    hi_factor: float
    fallback: float
    starts: tuple[float, ...] = ()
    # How far a real damper may depart from its drawing (factors of the spec's value):
    # a calibration within it is a spec's error; beyond it, a finding (diagnose's verdict
    # says so instead of "calibrated"). None: no such range (the spec gives 0, or the
    # value is a shape the drawing does not fix).
    tolerance: tuple[float, float] | None = None

    def scale(self, nominal: float) -> float:
        return nominal if nominal > 0 else self.fallback

    def bounds(self, nominal: float) -> tuple[float, float]:
        """The SI range it is calibrated within."""
        s = self.scale(nominal)
        return self.lo_factor * s, self.hi_factor * s

    def parameter(self, nominal: float) -> Parameter:
        return Parameter(
            self.name, GLOBAL, nominal, self.scale(nominal), self.lo_factor, self.hi_factor,
            self.unit,
        )  # fmt: skip


# Bounds as factors of the nominal value: wide enough for a real damper's departure from
# its drawing, narrow enough to keep the valve physical (no zero face area).
SPEC_GLOBALS: dict[str, SpecGlobal] = {
    g.name: g
    for g in (
        # Charged with a gauge to a few %, but a season's leak or a shop's over-charge
        # moves it by up to half or twice.
        SpecGlobal("gas_pressure_pa", "Pa", 0.2, 5.0, 1.0e6, tolerance=(0.5, 2.0)),
        # A new seal against a bedded one, a guide's fit: within a factor of two.
        SpecGlobal("friction_n", "N", 0.0, 6.0, 20.0, tolerance=(0.5, 2.0)),
        # A shim stack's preload and its face: the stack a drawing gives is built to tenths
        # of a mm, and the model's plate stands in for a real stack's beam (a wedge beam is
        # softer than the plate, which a calibrated face takes up): half to twice.
        SpecGlobal("compression_valve.preload_m", "m", 0.0, 5.0, 1.0e-4, tolerance=(0.5, 2.0)),
        SpecGlobal("compression_valve.face_area_m2", "m²", 0.2, 5.0, 1.0e-4, tolerance=(0.5, 2.0)),
        SpecGlobal("rebound_valve.preload_m", "m", 0.0, 5.0, 1.0e-4, tolerance=(0.5, 2.0)),
        SpecGlobal("rebound_valve.face_area_m2", "m²", 0.2, 5.0, 1.0e-4, tolerance=(0.5, 2.0)),
        # A sharp orifice (0) up to a 0.2 m laminar passage: a needle's land is mm to cm.
        SpecGlobal("bleed_land_m", "m", 0.0, 40.0, 5.0e-3),
        # A sharp-edged opening (0) up to a 5 mm seat land under the stacks: a piston's
        # seat lands are tenths of a mm to a few mm wide.
        SpecGlobal("valve_land_m", "m", 0.0, 5.0, 1.0e-3, (1.0e-3,)),
        # A rod seal deflects µm (a hard band) to a few tenths of a mm (a soft lip). Its
        # turn and an oil's compliance both soften the force after reversal: from the
        # spec's 0 beside a claimed compressibility, one fit took the turn as a 0.13x
        # smoothing speed with no travel (a reference sweep, seed 722); another, as 3.5 µm
        # of travel (seed 720). Hence the starts across that range.
        SpecGlobal("friction_presliding_m", "m", 0.0, 25.0, 2.0e-5, (2e-6, 1e-5, 5e-5, 2e-4)),
        # The paper smooths the friction's sign over 1 mm/s; a seal that turns over its
        # presliding travel needs less (a LuGre seal's steady state is the sign itself).
        SpecGlobal("friction_velocity_m_s", "m/s", 0.01, 5.0, 1.0e-3, (1e-4,)),
    )
}
# What `fit` calibrates; `diagnose` also calibrates the bleed's laminar land and the seal's
# presliding (diagnose/fitting.GLOBALS), which only the low-speed shape, the temperature
# and the turn of the friction at reversal show.
DIAGNOSE_ONLY = ("bleed_land_m", "valve_land_m", "friction_presliding_m", "friction_velocity_m_s")
DEFAULT_GLOBALS = tuple(k for k in SPEC_GLOBALS if k not in DIAGNOSE_ONLY)


def spec_global(name: str) -> SpecGlobal:
    """The declaration of a calibrated spec value (any other spec number: 0.2-5x, unitless)."""
    return SPEC_GLOBALS.get(name) or SpecGlobal(name, "", 0.2, 5.0, 1.0)


def global_parameters(spec: DamperSpec, names: Sequence[str] = DEFAULT_GLOBALS) -> list[Parameter]:
    """The spec values a calibration fits, each starting at the spec's value."""
    return [spec_global(n).parameter(spec.value(n)) for n in names]


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
    globals_start: Sequence[Parameter],
    terms_start: Mapping[str, tuple[float, float, float, float]],
    a_bc: FloatArray,
    a_bt: FloatArray,
    area_scale: float,
    a_max: float,
) -> ParameterSet:
    """The set a calibration fits: the globals, term parameters as name -> (value, scale,
    lo, hi) with lo, hi in scaled units, and every group's two areas from 0 to a_max."""
    items = list(globals_start)
    items += [Parameter(k, TERM, *v) for k, v in terms_start.items()]
    for kind, start in ((AREA_BC, a_bc), (AREA_BT, a_bt)):
        items += [
            Parameter(
                ParameterSet.area_name(kind, g), kind, float(a), area_scale, 0.0, a_max / area_scale
            )
            for g, a in enumerate(start)
        ]
    return ParameterSet(items)
