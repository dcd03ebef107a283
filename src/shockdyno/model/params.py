"""Declared parameters of physics terms: name, unit, nominal, bounds, scale, off value.

Like lmfit's parameter hints: a term says what each of its parameters means once, and
every consumer (the simulated rig, the fit, the fit JSON, diagnose, the report) reads it
from here. Names are namespaced by the term, `friction.breakaway_n`, so two terms never
clash. The `off` value is the one at which the term reduces exactly to the paper's model.
"""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass


@dataclass(frozen=True)
class SpecCalibration:
    """A term parameter that is a factor on one of the spec's values, which a recording
    calibrates before any physics is claimed (the diagnosis's baseline): while the factor
    stays `within` a spec's error it is the spec's value corrected, listed as calibration
    (row `spec_key`), not the term's physics. `quantity` and `effect` say it in words."""

    param: str  # the term's parameter (local name)
    spec_key: str  # the spec value it multiplies (DamperSpec.value)
    unit: str
    within: tuple[float, float]  # a spec's error, as factors
    quantity: str  # "gas volume"
    effect: str  # what the data see of it: "the gas spring rate"


@dataclass(frozen=True)
class Param:
    """One parameter of a term (local name; `Term.qualified` adds the namespace).

    `nominal` is the value a term starts from when switched on; `free` says whether a fit
    that names the term frees it (a parameter that a 0.5/1/1.5 Hz sweep cannot separate
    from another is held at its nominal value unless named as `term.param`).
    """

    name: str
    unit: str
    _: KW_ONLY  # the numbers by name: Param("x", "m", nominal=..., lo=..., hi=..., ...)
    nominal: float
    lo: float
    hi: float
    scale: float
    off: float
    free: bool = True
    doc: str = ""
    # A shape parameter that `diagnose` holds at its nominal where the term's fit leaves
    # its σ above this (the data reach too little of the shape to tell it): freed beside
    # the term's level, an undetermined shape trades with it and costs the term its claim.
    held_above_sd: float = math.inf

    def __post_init__(self) -> None:
        if not self.lo <= self.nominal <= self.hi:
            raise ValueError(f"{self.name}: nominal {self.nominal} outside [{self.lo}, {self.hi}]")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"{self.name}: scale must be a positive number")


@dataclass(frozen=True)
class Estimate:
    """A fitted parameter: value, 1-σ uncertainty (nan: not estimated), unit, flags."""

    value: float
    sd: float
    unit: str
    fixed: bool = False
    at_bound: bool = False
