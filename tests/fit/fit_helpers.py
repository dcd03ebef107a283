"""Known-truth damper and sweeps for the fit tests."""

from __future__ import annotations

from shockdyno.fit.problem import nominal_value
from shockdyno.fit.result import apply_overrides
from shockdyno.model import load_spec
from shockdyno.model.spec import DamperSpec

# The "real" damper departs from the nominal spec the fit starts from by 10-30 %.
TRUE_GLOBALS = {
    "gas_pressure_pa": 1.45e6,
    "friction_n": 45.0,
    "compression_valve.preload_m": 1.3e-4,
    "compression_valve.face_area_m2": 2.3e-4,
    "rebound_valve.preload_m": 1.8e-4,
    "rebound_valve.face_area_m2": 1.45e-4,
}


def true_spec() -> DamperSpec:
    return apply_overrides(load_spec(), TRUE_GLOBALS)


def nominal(key: str) -> float:
    return nominal_value(load_spec(), key)
