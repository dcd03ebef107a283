"""Known-truth damper and sweeps for the fit tests."""

from __future__ import annotations

from shockdyno.fit.synthetic import PERTURBED_GLOBALS
from shockdyno.model import load_spec
from shockdyno.model.spec import DamperSpec

TRUE_GLOBALS = PERTURBED_GLOBALS  # the "real" damper of these tests


def true_spec() -> DamperSpec:
    return load_spec().with_values(TRUE_GLOBALS)


def nominal(key: str) -> float:
    return load_spec().value(key)
