"""Fixtures of the ride tests: a fit result built from the default damper's true areas."""

from __future__ import annotations

import pytest

from shockdyno.fit.result import FitResult
from shockdyno.model import default_spec_path


@pytest.fixture(scope="session")
def true_fit() -> FitResult:
    """What a perfect fit of the simulated damper would give (independent of `fit`)."""
    return FitResult.from_spec(default_spec_path(), (5, 10, 15))
