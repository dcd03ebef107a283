"""Concealed effects, first part: air, cavitation and heat, a faint effect and a clean
recording (the cases and checks are in concealed.py; the others are in
test_diagnose_sim_pairs.py, a module of its own so that `--dist loadscope` can share them
between the test workers; two effects at once are bench_diagnose.py's pairs)."""

from __future__ import annotations

import json

import pytest
from concealed import (
    Diagnoses,
    Recordings,
    check_library_fits,
    check_named,
    check_names_hidden,
    claimed,
)

# Slow (2 min on one core): `pytest -m "not slow"` leaves it out; `make test` runs it.
pytestmark = [pytest.mark.timeout(900), pytest.mark.slow]  # diagnosed with the whole library
NAMES = ["clean", "s-air", "s-cav", "s-heat", "s-faint"]


def test_the_recordings_do_not_name_their_physics(recordings: Recordings) -> None:
    check_names_hidden(recordings, NAMES)


def test_a_clean_recording_claims_nothing(diagnoses: Diagnoses) -> None:
    d = diagnoses["clean"]
    assert d["verdict"]["physics"] == []
    assert not any(f["claimed"] for f in d["findings"])


@pytest.mark.parametrize("name", ["s-air", "s-cav", "s-heat"])
def test_a_concealed_effect_is_named(diagnoses: Diagnoses, name: str) -> None:
    check_named(diagnoses, name)


def test_the_release_pressure_is_the_simulated_one(diagnoses: Diagnoses) -> None:
    release = claimed(diagnoses, "s-cav", "cavitation")["release_pressure_pa"]["value"]
    assert release == pytest.approx(3.0e3, abs=5e3)


def test_a_faint_effect_is_not_claimed_or_claimed_small(diagnoses: Diagnoses) -> None:
    d = diagnoses["s-faint"]
    for f in d["findings"]:
        if f["claimed"]:
            assert f["effect_peak_n"] < 30.0


def test_the_json_has_every_documented_field(diagnoses: Diagnoses) -> None:
    d = diagnoses["s-air"]
    m = d["mismatch"]
    for key in ("significant", "p_value", "noise_floor_n", "structured_share", "where"):
        assert key in m
    for r in m["where"]:
        assert r["stroke"] in ("compression", "rebound", "both")
        assert len(r["x_range_m"]) == 2 and len(r["v_range_m_s"]) == 2 and 0 < r["share"] <= 1
    for f in d["findings"]:
        assert set(f) >= {
            "physics",
            "claimed",
            "p_value",
            "heldout_gain",
            "parameters",
            "ambiguous_with",
        }
    assert set(d["verdict"]) >= {"physics", "unexplained", "text"}
    assert set(d["tests"][0]) >= {"index", "clicks", "frequency_hz", "E_t_before", "E_t_after"}
    json.dumps(d, allow_nan=False)


@pytest.mark.parametrize("name", ["s-air", "s-cav", "s-heat"])
def test_the_library_at_the_simulated_values_fits_the_recording_to_noise(
    recordings: Recordings, name: str
) -> None:
    check_library_fits(recordings, name)
