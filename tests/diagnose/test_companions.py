"""A term that needs a calibration beside it (fitting.COMPANIONS) frees it as a candidate,
and a term retested or dropped is judged without it: seal friction and the seal's travel
(its presliding; not the smoothing speed, which stays the spec's)."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.diagnose.candidates import binned_means, companion_keys, try_candidate
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import CALIBRATIONS, refit
from shockdyno.diagnose.search import without
from shockdyno.diagnose.stats import noise_draws
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec

TURN = CALIBRATIONS["seal_turn"]


def test_friction_frees_the_seal_travel_and_takes_it_out_again() -> None:
    spec = load_spec(None)
    # The damper's seal turns over 0.3 mm of presliding; its spec says a sharp sign.
    real = spec.with_values({"friction_presliding_m": 3e-4})
    tests = synthetic_sweep(real, [5, 15], cycles=3, seed=4)
    prepared, _ = prepare_tests(tests)
    data = Data.build(spec, prepared)
    base = refit(data, DamperModel(spec), (), None, max_nfev=30)
    assert not set(TURN) & set(base.globals)
    assert companion_keys(base, "friction") == ("friction_presliding_m",)
    assert companion_keys(base, "compressibility") == ()
    means, binned = binned_means(data, base.residual)
    noise = noise_draws(binned, np.random.default_rng(0), 99)
    c = try_candidate(data, base, means, "friction", noise, 20)
    assert "friction_presliding_m" in c.fitted.globals
    assert "friction_velocity_m_s" not in c.fitted.globals
    # The travel was calibrated with it: the presliding moved off the spec's 0 toward 0.3 mm.
    got = c.fitted.model.spec.friction_presliding_m
    assert 1e-4 < got < 1e-3, got
    assert c.fitted.model.spec.friction_velocity_m_s == spec.friction_velocity_m_s
    # Taken out, the term leaves no friction parameter free and the turn at the spec's.
    came = {"friction": companion_keys(base, "friction")}
    model, free, calibrated = without(data, c.fitted, ["friction"], came)
    assert model.term("friction") is None
    assert not any(q.startswith("friction.") for q in free)
    assert calibrated == base.globals
    assert model.spec.friction_presliding_m == spec.friction_presliding_m
    assert model.spec.friction_velocity_m_s == pytest.approx(spec.friction_velocity_m_s)
    # A travel the fit calibrated before (a calibration taken on its own) stays.
    model2, _, calibrated2 = without(data, c.fitted, ["friction"], {"friction": ()})
    assert "friction_presliding_m" in calibrated2
    assert model2.spec.friction_presliding_m == c.fitted.model.spec.friction_presliding_m
