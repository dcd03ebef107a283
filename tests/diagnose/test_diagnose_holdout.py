"""Concealed effects on the held-out plant (tests/holdout/plant.py: a damper written from
first principles by someone who had not read the project's physics, in forms of its own:
an elastic seal lip with an exponential Stribeck reset, a bump rubber that densifies, with
rate hysteresis; a 4-pole Butterworth anti-alias on both channels). Each sweep is written
as CSV exchange files and imported, as a user would, then diagnosed with the whole library
and the default spec. The diagnosis must claim nothing on the clean plant, and name each
effect and model it to near the clean sweep's own error."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from holdout.plant import Effects
from holdout.recording import holdout_recording
from shockdyno.diagnose.file import diagnose_file

pytestmark = [pytest.mark.timeout(600), pytest.mark.slow]

CLICKS = (2, 12)
FREQS = (0.5, 1.0, 1.5)
SEED = 3  # the held-out plant's first seed no rule was looked at on
# The middle of bench_holdout.py's fric_mid and contact_mid ranges, fixed before any
# diagnosis of this plant was run in the suite.
HIDDEN = {
    "clean": Effects(),
    "h-seal": Effects(
        breakaway_n=85.0, stribeck_velocity_m_s=0.005, lip_travel_m=1e-4, seal_viscous_n_s_m=90.0
    ),
    "h-bump": Effects(bump_onset_m=0.024, bump_k_n_m=45e3),
}


@pytest.fixture(scope="module")
def diagnosed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    out = {}
    for name, fx in HIDDEN.items():
        rec, truth = holdout_recording(
            fx, tmp_path_factory.mktemp(name), SEED, clicks=CLICKS, freqs=FREQS
        )
        _, doc = diagnose_file(Path(rec))
        out[name] = {"truth": truth.physics(), "doc": doc}
    return out


def _claimed(d: dict[str, Any], physics: str) -> dict[str, float]:
    (f,) = [f for f in d["findings"] if f["physics"] == physics and f["claimed"]]
    return {k: p["value"] for k, p in f["parameters"].items()}


def _assert_explained(d: dict[str, Any], clean: dict[str, Any]) -> None:
    """Modelled to near the clean sweep's own level, and well below where it started."""
    before = np.mean([t["E_t_before"] for t in d["tests"]])
    after = np.mean([t["E_t_after"] for t in d["tests"]])
    floor = np.mean([t["E_t_after"] for t in clean["tests"]])
    assert after < 0.5 * before and after <= 1.5 * floor, (
        before,
        after,
        floor,
        d["verdict"]["text"],
    )


def test_the_plant_did_what_each_case_asks(diagnosed) -> None:
    assert {n: d["truth"] for n, d in diagnosed.items()} == {
        "clean": [],
        "h-seal": ["friction"],
        "h-bump": ["contact"],
    }


def test_a_clean_held_out_sweep_claims_nothing(diagnosed) -> None:
    d = diagnosed["clean"]["doc"]
    assert d["verdict"]["physics"] == [], d["verdict"]["text"]


def test_a_held_out_seal_lip_is_named_friction_and_modelled(diagnosed) -> None:
    d = diagnosed["h-seal"]["doc"]
    assert d["verdict"]["physics"] == ["friction"], d["verdict"]["text"]
    _assert_explained(d, diagnosed["clean"]["doc"])


def test_a_held_out_bump_rubber_is_named_at_its_onset(diagnosed) -> None:
    d = diagnosed["h-bump"]["doc"]
    assert d["verdict"]["physics"] == ["contact"], d["verdict"]["text"]
    assert _claimed(d, "contact")["bump_onset_m"] == pytest.approx(0.024, abs=0.002)


@pytest.mark.xfail(
    strict=True,
    reason="a finding: the library's power-law bump leaves the rubber's densification and "
    "rate hysteresis (measured at seed 3: E_t 0.1127 -> 0.0115 against the clean 0.0037, "
    "3.1x)",
)
def test_a_held_out_bump_rubber_is_modelled_to_the_clean_level(diagnosed) -> None:
    _assert_explained(diagnosed["h-bump"]["doc"], diagnosed["clean"]["doc"])
