"""A shape parameter the data cannot tell (`Param.held_above_sd`: a bump stop's exponent)
is held at its nominal and the term fitted again without it; one the data fix stays free."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shockdyno.diagnose.candidates import _undetermined
from shockdyno.diagnose.fitting import Fitted
from shockdyno.model import DamperModel, load_spec
from shockdyno.model.terms import make_term

N = "contact.exponent"


def _fitted(sd: float, free: tuple[str, ...] = (N, "contact.bump_force_n")) -> Fitted:
    model = DamperModel(load_spec(None), (make_term("contact"),), {N: 1.4})
    sds = {k: 0.1 for k in free} | ({N: sd} if N in free else {})
    return Fitted(model, free, {}, sds, np.zeros(0), np.zeros(0))


@pytest.mark.parametrize("sd", [0.84, 0.26, math.inf, math.nan])
def test_an_exponent_the_fit_leaves_undetermined_is_held_at_two(sd: float) -> None:
    assert _undetermined(_fitted(sd), "contact") == {N: 2.0}


@pytest.mark.parametrize("sd", [0.006, 0.25])
def test_an_exponent_the_data_fix_stays_free(sd: float) -> None:
    assert _undetermined(_fitted(sd), "contact") == {}


def test_a_held_exponent_or_another_term_is_left_alone() -> None:
    assert _undetermined(_fitted(0.84, ("contact.bump_force_n",)), "contact") == {}
    assert _undetermined(_fitted(0.84), "friction") == {}


def test_the_exponent_is_freed_with_the_contact_term() -> None:
    assert make_term("contact").nesting_free().count("exponent") == 1
