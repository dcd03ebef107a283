"""The fixture mass term: F = m ẍ, checked against the closed form on a sine, fitted back
from a sweep that carries one, and its words."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from shockdyno.fit.sweep import fit_sweep
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model import load_spec
from shockdyno.model.composite import DamperModel, ModelInputs
from shockdyno.model.params import Estimate
from shockdyno.model.reading import Reading
from shockdyno.model.terms import LIBRARY, make_term
from shockdyno.model.terms.fixture_mass import FixtureMass


def _sine(f_hz: float, amp: float = 0.03, n: int = 2000) -> ModelInputs:
    w = 2 * math.pi * f_hz
    t = np.arange(n) * 1e-3
    x = amp * np.sin(w * t)
    return ModelInputs.single(x, amp * w * np.cos(w * t), -(w**2) * x)


def test_its_force_is_the_mass_times_the_acceleration_a_spring_of_rate_m_omega_squared() -> None:
    spec = load_spec()
    for f_hz in (0.5, 1.5):
        inputs = _sine(f_hz)
        model = DamperModel(spec, (make_term("fixture_mass"),), {"fixture_mass.mass_kg": 7.0})
        ev = model.evaluate(inputs, 1e-6, 1e-6)
        part = ev.components["fixture_mass"]
        # on a sine m ẍ = -m ω² x: a spring whose rate grows with the frequency squared
        rate = -7.0 * (2 * math.pi * f_hz) ** 2
        assert np.allclose(part, rate * inputs.x, rtol=1e-12, atol=1e-12)
        off = model.off().evaluate(inputs, 1e-6, 1e-6)
        assert np.allclose(ev.force - off.force, part, atol=1e-9)


def test_it_is_in_the_library_and_left_out_of_the_car() -> None:
    assert LIBRARY["fixture_mass"] is FixtureMass
    model = DamperModel(load_spec(), (make_term("fixture_mass"),))
    assert model.vehicle().terms == ()


def test_a_mass_more_negative_than_the_rod_is_not_physics() -> None:
    spec = load_spec()
    term = FixtureMass()
    assert term.implausible({"mass_kg": -0.5 * spec.piston_rod_mass_kg}, spec) == ""
    assert "more negative than the rod" in term.implausible(
        {"mass_kg": -spec.piston_rod_mass_kg - 1.0}, spec
    )


def test_its_words_name_the_mass_and_its_sigma() -> None:
    r = Reading(FixtureMass.PARAMS, {"mass_kg": Estimate(7.8, 0.21, "kg")})
    text = FixtureMass().describe(r)
    assert text.startswith("fixture mass: 7.8 ± 0.21 kg between the load cell")
    r = Reading(FixtureMass.PARAMS, {"mass_kg": Estimate(-0.4, 0.05, "kg")})
    assert "does not feel the rod's own inertia" in FixtureMass().describe(r)


def test_a_sweep_carrying_a_fixture_mass_gives_it_back_when_fitted() -> None:
    spec = load_spec()
    tests = synthetic_sweep(spec, [4, 14], cycles=2, seed=5)
    mass = 6.0
    tests = [
        replace(t, force=t.force - mass * (2 * math.pi * t.meta.frequency_hz) ** 2 * t.x)
        for t in tests
    ]
    fit = fit_sweep(tests, terms="fixture_mass")
    got = fit.terms["fixture_mass"]["mass_kg"]
    assert got.value == pytest.approx(mass, rel=0.1), got
    plain = fit_sweep(tests, terms="none")
    e_t = [t.proposed["E_t"] for t in fit.tests]
    assert np.mean(e_t) < np.mean([t.proposed["E_t"] for t in plain.tests])
