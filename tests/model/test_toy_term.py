"""A term is one class: a new physics written once (its parameters, force, words and the
test that separates it) is fitted, diagnosed, worded, reported and carried to the car,
with no other file told of it."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import ClassVar

import pytest

from shockdyno.cli import main
from shockdyno.diagnose.claims import separate_by
from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.verdict import to_json
from shockdyno.fit.result import FitResult
from shockdyno.fit.sweep import fit_sweep
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model import load_spec
from shockdyno.model.composite import FORCE, FloatArray, Term, Work
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading
from shockdyno.model.terms import LIBRARY
from shockdyno.record.types import TestData
from shockdyno.report.build import build_report
from shockdyno.ride.study import RideConfig, run_study

MASS_KG = 40.0


class ToyMass(Term):
    """A mass moving with the rod: F = m·a."""

    name = "toy_mass"
    stage = FORCE
    summary = "a mass moving with the rod"
    separated_by: ClassVar[dict[str, str]] = {
        "gas_spring": "tests at other frequencies (m·a grows with f², gas does not)"
    }
    PARAMS = (
        Param(
            "mass_kg", "kg", nominal=10.0, lo=0.0, hi=500.0, scale=10.0, off=0.0, doc="moving mass"
        ),
    )

    def describe(self, r: Reading) -> str:
        return f"toy mass: {r.v('mass_kg'):.3g}{r.sd('mass_kg')} kg moving with the rod"

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        w.add_part(self.name, p["mass_kg"] * w.a)
        return None


@pytest.fixture
def toy(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(LIBRARY, ToyMass.name, ToyMass)


def _sweep_with_mass() -> list[TestData]:
    tests = synthetic_sweep(load_spec(), [4, 14], cycles=2, seed=3)
    # m·a of the sine the rod follows
    mass = [MASS_KG * -((2 * math.pi * t.meta.frequency_hz) ** 2) * t.x for t in tests]
    return [replace(t, force=t.force + f) for t, f in zip(tests, mass, strict=True)]


def test_a_term_registered_once_is_fitted_diagnosed_reported_and_driven(
    toy: None, tmp_path: Path
) -> None:
    tests = _sweep_with_mass()

    fit = fit_sweep(tests, terms="toy_mass")
    mass = fit.terms["toy_mass"]["mass_kg"]
    assert mass.value == pytest.approx(MASS_KG, rel=0.15), mass
    fit.save(tmp_path / "fit.json")
    back = FitResult.load(tmp_path / "fit.json")  # the JSON names it; reading it builds it
    assert [t.name for t in back.model().terms] == ["toy_mass"]

    diag = diagnose(tests, settings=Settings(candidates=("toy_mass",), n_boot=199))
    doc = to_json(diag)
    assert doc["verdict"]["physics"] == ["toy_mass"], doc["verdict"]["text"]
    assert "kg moving with the rod" in doc["verdict"]["text"]
    assert separate_by("gas_spring", "toy_mass").startswith("tests at other frequencies")

    index = build_report(tests, tmp_path / "report", title="toy", fit=fit, diagnose=doc)
    assert "kg moving with the rod" in index.read_text()

    ride = run_study(
        RideConfig(clicks=(4,), roads=("C",), speeds_kmh=(60.0,), duration_s=6.0, warmup_s=2.0),
        fit,
    )
    assert ride.damper_info.terms == ("toy_mass",)


def test_a_registered_term_is_listed_in_fit_and_diagnose_help(
    toy: None, capsys: pytest.CaptureFixture[str]
) -> None:
    for command in ("fit", "diagnose"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        out = " ".join(capsys.readouterr().out.split())  # unwrapped
        assert "toy_mass: a mass moving with the rod" in out, command
        assert "friction: Stribeck seal friction" in out


def test_without_the_class_the_name_is_unknown() -> None:
    # The test above is not vacuous: nothing else in the project knows the toy.
    assert "toy_mass" not in LIBRARY
    with pytest.raises(Exception, match="toy_mass"):
        fit_sweep(_sweep_with_mass(), terms="toy_mass")
