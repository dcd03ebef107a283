"""The breakaway a diagnosis reports is the force the seal reaches at reversal on the
recording (what a dyno engineer reads), checked against a plant in its own forms: the
reference plant's elasto-plastic seal with a Hess-Soom level (simrig/reference.py), whose
sweep records the largest force its seal reached. Neither that plant nor the library's seal
reaches its static level F_c + F_b on a reversing sine (the rod is past the Stribeck speed
before the seal has turned), so the level is not what is compared."""

from __future__ import annotations

import re

import pytest

from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.verdict import to_json
from shockdyno.model.spec import load_spec
from shockdyno.simrig.reference import PlantParams, reference_sweep

BREAKAWAY_N = 60.0  # the plant's static force above its Coulomb level


@pytest.fixture(scope="module")
def seal_sweep() -> tuple[dict[str, object], float]:
    spec = load_spec(None)
    tests, truth = reference_sweep(spec, PlantParams(breakaway_n=BREAKAWAY_N), [5, 15], (0.5, 1.5))
    # Friction only: the readout is what is tested, not the search among the library.
    d = to_json(diagnose(tests, settings=Settings(candidates=("friction",))))
    return d, truth.seal_peak_n


def test_the_plant_seal_does_not_reach_its_static_level_on_the_sweep(
    seal_sweep: tuple[dict[str, object], float],
) -> None:
    _, peak = seal_sweep
    static = load_spec(None).friction_n + BREAKAWAY_N
    assert load_spec(None).friction_n < peak < 0.95 * static, (peak, static)


def test_the_reported_breakaway_is_the_force_the_seal_reaches(
    seal_sweep: tuple[dict[str, object], float],
) -> None:
    d, peak = seal_sweep
    (found,) = [f for f in d["findings"] if f["physics"] == "friction"]  # type: ignore[attr-defined]
    assert found["claimed"], found["why_not"]
    reached = found["parameters"]["breakaway_reached_n"]["value"]
    assert reached == pytest.approx(peak, rel=0.15)
    # The verdict's words give that force, Coulomb included, not the Stribeck level above it.
    said = re.search(r"breakaway ([0-9.]+) N", d["verdict"]["text"])  # type: ignore[index]
    assert said is not None, d["verdict"]["text"]  # type: ignore[index]
    assert float(said.group(1)) == pytest.approx(peak, rel=0.15)
