"""A shape parameter the data cannot tell (`Param.held_above_sd`: a bump stop's exponent)
is held at its nominal and the term fitted again without it; one the data fix stays free."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from shockdyno.diagnose.candidates import _undetermined, freed_shapes
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import Fitted, refit
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
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


def test_a_shape_held_by_a_short_refit_is_freed_where_the_end_fit_tells_it() -> None:
    """The final refit frees a held exponent again (`freed_shapes`) and keeps it where its
    σ is within the bound there; an off side's exponent, with no column, stays held."""
    spec = load_spec(None)
    onset, force, n = 0.018, 300.0, 3.0  # 12 mm deep, F ∝ depth³
    clean = synthetic_sweep(spec, [5, 15], cycles=3, seed=4)
    bumped = [
        replace(t, force=t.force + force * (np.maximum(t.x - onset, 0.0) / 0.01) ** n)
        for t in clean
    ]
    data = Data.build(spec, prepare_tests(bumped)[0])
    # The damper's areas from the sweep without the stop, as the search's would be near.
    base = refit(Data.build(spec, prepare_tests(clean)[0]), DamperModel(spec), (), None, 30)
    start = {"contact.bump_onset_m": onset, "contact.bump_force_n": force}
    model = base.model.with_terms([make_term("contact")]).with_values(
        start | {"contact.topout_force_n": 0.0, "contact.topout_onset_m": -0.2}
    )
    # As a candidate leaves it: both exponents held at 2, the top-out off.
    held = refit(data, model, tuple(start), base, max_nfev=30)
    assert held.model.value(N) == 2.0
    freed = freed_shapes(data, held, ["contact"], 60)
    assert N in freed.free and "contact.topout_exponent" not in freed.free
    assert "contact.hysteresis_velocity_m_s" not in freed.free  # no loss: it moves nothing
    assert freed.term_sd[N] <= 0.25
    assert freed.model.value(N) == pytest.approx(n, abs=max(0.05, 3 * freed.term_sd[N]))
    assert freed.model.value("contact.bump_onset_m") == pytest.approx(onset, abs=5e-4)
    assert float(freed.residual @ freed.residual) < 0.75 * float(held.residual @ held.residual)
    assert freed_shapes(data, freed, ["contact"], 60) is freed  # nothing held: unchanged
