"""Concealed effects on the reference plant (simrig/reference.py): physics that the library's
terms were not written with (its own chambers, anti-alias filter and skewed force channel,
quadratic bump stop), integrated by a stiff solver. The diagnosis sees only the tests; it
must name the effect, place it where the plant has it, and claim nothing on a clean
sweep. The sweeps are offline (no sockets: the stiff solver is slower than real time)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from concealed import PHYSICS_WORDS

from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.verdict import to_json
from shockdyno.model import load_spec
from shockdyno.simrig.reference import PlantParams, reference_sweep

pytestmark = [pytest.mark.timeout(600), pytest.mark.slow]

CLICKS = [2, 10, 20]
SEED = 754  # no rule was looked at on it
HIDDEN = {
    "clean": {},
    "r-skew": {"force_skew_s": 0.004},
    "r-bump": {"bump_onset_m": 0.021, "bump_force_at_10mm_n": 200.0},
}


@pytest.fixture(scope="module")
def diagnosed() -> dict[str, tuple[list[Any], dict[str, Any]]]:
    spec = load_spec()
    out = {}
    for name, params in HIDDEN.items():
        tests, _ = reference_sweep(spec, PlantParams(**params), CLICKS, seed=SEED)
        out[name] = (tests, to_json(diagnose(tests)))
    return out


def _claimed(d: dict[str, Any], physics: str) -> dict[str, float]:
    (f,) = [f for f in d["findings"] if f["physics"] == physics and f["claimed"]]
    return {k: p["value"] for k, p in f["parameters"].items()}


def test_the_tests_do_not_name_their_physics(diagnosed) -> None:
    for tests, _ in diagnosed.values():
        text = repr([t.meta for t in tests]).lower()
        assert not any(w in text for w in PHYSICS_WORDS)


def test_a_clean_reference_sweep_claims_nothing(diagnosed) -> None:
    _, d = diagnosed["clean"]
    assert d["verdict"]["physics"] == [], d["verdict"]["text"]


def test_a_skewed_force_channel_is_named_with_its_time(diagnosed) -> None:
    _, d = diagnosed["r-skew"]
    assert d["verdict"]["physics"] == ["sensor_lag"], d["verdict"]["text"]
    v = _claimed(d, "sensor_lag")
    delay = v.get("delay_s", 0.0) + v.get("load_cell_lag_s", 0.0)
    assert delay == pytest.approx(0.004, rel=0.25)
    _assert_explained(d, diagnosed["clean"][1])


def test_a_bump_stop_is_named_at_its_onset(diagnosed) -> None:
    _, d = diagnosed["r-bump"]
    assert d["verdict"]["physics"] == ["contact"], d["verdict"]["text"]
    assert _claimed(d, "contact")["bump_onset_m"] == pytest.approx(0.021, abs=0.002)
    _assert_explained(d, diagnosed["clean"][1])


def _assert_explained(d: dict[str, Any], clean: dict[str, Any]) -> None:
    """Modelled to near the clean sweep's own level, and well below where it started."""
    before = np.mean([t["E_t_before"] for t in d["tests"]])
    after = np.mean([t["E_t_after"] for t in d["tests"]])
    floor = np.mean([t["E_t_after"] for t in clean["tests"]])
    assert after < 0.5 * before and after <= 1.5 * floor, (before, after, floor)
