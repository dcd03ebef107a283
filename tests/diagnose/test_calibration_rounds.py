"""After a claim that leaves nothing beyond noise for physics, the calibrations that lost
their round to it still get rounds of their own (diagnose/search.py, Search.run)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import pytest

from shockdyno.diagnose import engine, search
from shockdyno.diagnose.fitting import CALIBRATIONS
from shockdyno.diagnose.search import Search, gated
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.stats import MismatchStat
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.spec import load_spec


def _run(monkeypatch: pytest.MonkeyPatch, delay_s: float) -> tuple[list[list[str]], Any]:
    spec = load_spec(None)
    # A seal that deflects 20 µm before it slides, where the spec says a sharp sign.
    real = spec.with_values({"friction_presliding_m": 2e-5, "friction_velocity_m_s": 1e-4})
    tests = synthetic_sweep(real, [15], cycles=4, seed=7, force_delay_s=delay_s, ripple_m=0.0)
    rounds: list[list[str]] = []
    real_round, real_test = Search.round, engine.mismatch_test
    calls = [0]

    def round_(self: Search, rnd: int, remaining: list[str]) -> Any:
        rounds.append(list(remaining))
        return real_round(self, rnd, remaining)

    def quiet_after_first(*args: Any, **kwargs: Any) -> MismatchStat:
        # What is left after the first round shows nothing beyond noise (the gate).
        calls[0] += 1
        got = real_test(*args, **kwargs)
        return got if calls[0] == 1 else replace(got, p_value=1.0)

    monkeypatch.setattr(Search, "round", round_)
    # The baseline's test is engine's, what each round leaves the search's.
    monkeypatch.setattr(engine, "mismatch_test", quiet_after_first)
    monkeypatch.setattr(search, "mismatch_test", quiet_after_first)
    s = Settings(candidates=("sensor_lag",), calibrations=("seal_turn",), n_boot=199)
    return rounds, engine.diagnose(tests, settings=s)


def test_a_claim_at_noise_still_lets_the_calibrations_have_their_round(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A 4 ms channel skew (sensor_lag) wins round 1 on likelihood over the seal's turn.
    rounds, d = _run(monkeypatch, 0.004)
    assert d.claimed == ["sensor_lag"], d.claimed
    assert len(rounds) == 2 and rounds[1] == ["seal_turn"], rounds
    turn = {c.parameter: c for c in d.calibration if c.parameter in CALIBRATIONS["seal_turn"]}
    assert turn["friction_presliding_m"].fitted == pytest.approx(2e-5, rel=0.3)


def test_no_claim_and_nothing_beyond_noise_ends_the_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    rounds, d = _run(monkeypatch, 0.0)
    assert not d.claimed
    # The seal's turn wins round 1 (a calibration, not a claim); nothing more is tried.
    assert len(rounds) == 1, rounds


def _left(p: float) -> MismatchStat:
    return MismatchStat(p, 100.0, 3.0, 2.0, 0.5, 40.0)


@pytest.mark.parametrize(
    ("p", "claimed", "outranked", "expected"),
    [
        # Structure beyond noise and room for a term: every candidate.
        (0.001, ["compressibility"], [], ["friction", "thermal", "seal_turn", "bleed_land"]),
        # Within noise after a claim: the calibrations not yet taken.
        (0.5, ["compressibility"], [], ["seal_turn", "bleed_land"]),
        # ... and a term that passed every rule but lost its round to a calibration.
        (0.5, ["compressibility"], ["friction"], ["friction", "seal_turn", "bleed_land"]),
        # Nothing claimed and nothing beyond noise: the search ends.
        (0.5, [], ["friction"], []),
        # max_terms claimed: calibrations only, whatever passed before.
        (
            0.001,
            ["compressibility", "thermal", "contact"],
            ["friction"],
            ["seal_turn", "bleed_land"],
        ),
    ],
)
def test_what_the_next_round_tries(
    p: float, claimed: list[str], outranked: list[str], expected: list[str]
) -> None:
    remaining = ["friction", "thermal", "seal_turn", "bleed_land"]
    got = gated(remaining, _left(p), claimed, outranked, Settings())
    assert got == [c for c in remaining if c in expected]
