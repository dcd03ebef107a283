"""Fixtures of the ride tests: a fit result built from the default damper's true areas."""

from __future__ import annotations

import pytest

from shockdyno.fit.result import ClickFit, FitResult
from shockdyno.model import default_spec_path, load_spec


@pytest.fixture(scope="session")
def true_fit() -> FitResult:
    """What a perfect fit of the simulated damper would give (independent of `fit`)."""
    spec = load_spec()
    clicks = []
    for n in (5, 10, 15):
        a_bc, a_bt = spec.bleed_areas(n)
        clicks.append(ClickFit(n, 0, float(a_bc), float(a_bt), float(0.5 * (a_bc + a_bt))))
    return FitResult(spec_path=str(default_spec_path()), globals={}, clicks=clicks)
