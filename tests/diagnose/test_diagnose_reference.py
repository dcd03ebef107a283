"""Concealed effects on the reference plant (simrig/reference.py): a damper whose every
equation is other than the library's (docs/diagnose-method.md has the table, form by form): here
Tait oil carrying 1 % free air through the piston, and an elasto-plastic rod seal with a
Hess-Soom breakaway. The diagnosis sees only the tests; it must name the air, model each
effect to near the clean sweep's own error with the plant's own numbers, claim nothing
on a clean sweep, and nothing but friction on the seal's (this plant's seal is named on a
few seeds only: benchmarks/results/turn-steps-2026-11-30.txt). The sweeps are offline
(reference_sweep: no sockets); each is made and diagnosed when a test first asks for it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from concealed import PHYSICS_WORDS
from plants import Made, assert_modelled, claimed_values

from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.verdict import to_json
from shockdyno.model import load_spec
from shockdyno.simrig.reference import PlantParams, ReferencePlant, reference_sweep

# A diagnosis takes 30-90 s of CPU here; a loaded machine gave the first test (then the
# whole module's three) a fifth of a core.
pytestmark = [pytest.mark.timeout(900), pytest.mark.slow]

CLICKS = [2, 12]
FREQS = (0.5, 1.5)  # four tests: the air alone took 149 s of CPU to diagnose on six
SEED = 755  # the first seed of the rewritten plant; no rule was looked at on it
# Fixed before any diagnosis of the rewritten plant was run.
HIDDEN: dict[str, dict[str, float]] = {
    "clean": {},
    "r-air": {"oil_bulk_modulus_pa": 1.6e9, "air_fraction": 0.01},
    "r-seal": {"breakaway_n": 40.0},
}


@pytest.fixture(scope="module")
def sweeps() -> Made:
    spec = load_spec()
    return Made(
        lambda name: reference_sweep(spec, PlantParams(**HIDDEN[name]), CLICKS, FREQS, seed=SEED)[0]
    )


@pytest.fixture(scope="module")
def diagnosed(sweeps: Made, tmp_path_factory: pytest.TempPathFactory) -> Made:
    where = tmp_path_factory.mktemp("reference")

    def make(name: str) -> dict[str, Any]:
        doc = to_json(diagnose(sweeps[name]))
        (Path(where) / f"{name}.json").write_text(json.dumps(doc, default=str))  # to read after
        return doc

    return Made(make)


def test_the_tests_do_not_name_their_physics(sweeps: Made) -> None:
    for name in HIDDEN:
        text = repr([t.meta for t in sweeps[name]]).lower()
        assert not any(w in text for w in PHYSICS_WORDS)


def test_a_clean_reference_sweep_claims_nothing(diagnosed: Made) -> None:
    d = diagnosed["clean"]
    assert d["verdict"]["physics"] == [], d["verdict"]["text"]


def test_air_carried_in_tait_oil_is_named_compressibility(diagnosed: Made) -> None:
    d = diagnosed["r-air"]
    assert d["verdict"]["physics"] == ["compressibility"], d["verdict"]["text"]


@pytest.mark.xfail(
    strict=True,
    reason="a finding: Wood's law with a constant oil modulus reads 185.3 MPa at the charge "
    "where the plant's Tait oil with 1 % carried air is 145.7 MPa (+27 %; seed 755)",
)
def test_air_carried_in_tait_oil_is_read_at_its_modulus(diagnosed: Made) -> None:
    spec = load_spec()
    charge = spec.gas_pressure_pa
    plant = ReferencePlant(spec, PlantParams(**HIDDEN["r-air"]), 1000.0)
    v = claimed_values(diagnosed["r-air"], "compressibility")
    a, c = v.get("air_fraction", 0.0), v.get("oil_compressibility_per_gpa", 0.0) * 1e-9
    reported = 1 / ((1 - a) * c + a / charge)
    assert reported == pytest.approx(plant.bulk_modulus_pa(charge), rel=0.25)


def test_air_carried_in_tait_oil_is_modelled(diagnosed: Made) -> None:
    """Within 2x the clean sweep's E_t after, not the scoreboard's 1.5x: the clean sweep's
    own level moves with the calibrations its diagnosis takes on the last bits of the
    arithmetic (0.0102 with the stacks' seat land, 0.0124 with the seal's presliding,
    0.0134 with neither, on two machines), where the air's stays at 0.0156 (1.16-1.53x).
    The 1.5x bar is judged over many seeds by bench_reference.py, not on one here."""
    assert_modelled(diagnosed["r-air"], diagnosed["clean"], times=2.0)


def test_an_elasto_plastic_seal_is_named_friction_or_left_unnamed(diagnosed: Made) -> None:
    """Not a claim of anything else (on six tests of this seed a negative delay was once
    claimed). Naming it is not asserted: at 40 N the library's Stribeck seal, trained on one
    frequency, predicts the other worse than without it on most seeds, and where it was
    named here its share in place stood within its noise of the half a claim needs (the
    figures are in the record the module's docstring names)."""
    d = diagnosed["r-seal"]
    assert d["verdict"]["physics"] in ([], ["friction"]), d["verdict"]["text"]
    tried = [f for f in d["findings"] if f["physics"] == "friction"]
    assert tried and all(f["claimed"] or f["why_not"] for f in tried)


@pytest.mark.xfail(
    strict=True,
    reason="a finding: on this seed the seal is not named (the test above); where it was, "
    "the Stribeck term read 69.8 N of breakaway for the plant's Hess-Soom level of 40 N "
    "(+75 %)",
)
def test_an_elasto_plastic_seal_is_read_at_its_breakaway(diagnosed: Made) -> None:
    v = claimed_values(diagnosed["r-seal"], "friction")
    assert v["breakaway_n"] == pytest.approx(40.0, rel=0.25)


def test_an_elasto_plastic_seal_is_modelled(diagnosed: Made) -> None:
    assert_modelled(diagnosed["r-seal"], diagnosed["clean"])
