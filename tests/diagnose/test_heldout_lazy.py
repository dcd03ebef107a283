"""A round scores held out only the candidates whose gain decides something
(claims.Judge.score_heldout), and decides what scoring every candidate decides: the same claim,
the same claimable ones beside a claimed calibration (the next round's `outranked`), the
same "cannot tell apart" pairs, the same gain for each of those. Checked against scoring
them all on many random rounds (LRs, p-values, other rules' refusals, gains, shapes),
with the held-out refits replaced by a table of gains that counts what it is asked."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np
import pytest

from shockdyno.diagnose import claims as claim_rules
from shockdyno.diagnose.candidates import Candidate
from shockdyno.diagnose.claims import decide, why_not
from shockdyno.diagnose.fitting import CALIBRATIONS, Fitted
from shockdyno.diagnose.settings import Settings
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec
from shockdyno.model.terms.position_force import PositionForce

SPEC = load_spec(None)
N = 60  # phase means of the explained shapes


class Fake:
    """HeldOut's stand-in: each candidate's gain from a table; what was asked, in order,
    and what was refitted ahead of being asked (HeldOut.prefetch)."""

    asked: ClassVar[list[str]] = []
    table: ClassVar[dict[str, float]] = {}
    prefetched: ClassVar[list[str]] = []

    def __init__(self, *args: object) -> None:
        pass

    def prefetch(self, cands: Sequence[Candidate]) -> None:
        Fake.prefetched += [c.name for c in cands]

    def gains(self, cands: Sequence[Candidate]) -> list[tuple[float, str]]:
        Fake.asked += [c.name for c in cands]
        return [(Fake.table[c.name], f"folds of {c.name}") for c in cands]


def _candidate(name: str, lr: float, p: float, explained: np.ndarray, peak: float) -> Candidate:
    fitted = Fitted(DamperModel(SPEC), (), {}, {}, np.zeros(0), np.zeros(0))
    moved = {"bleed_land_m": 0.05, "friction_presliding_m": 1.0, "friction_velocity_m_s": 1.0}
    spec_values = {k: v for k, v in moved.items() if name in ("bleed_land", "seal_turn")}
    return Candidate(name, fitted, lr, p, peak, peak, explained, spec_values=spec_values)


def _round(rng: np.random.Generator, s: Settings) -> tuple[list[Candidate], dict[str, str]]:
    """A random round: physics-like names (no term in the model, so only the rules the
    test controls apply), the open set, the two calibrations; shapes drawn from a few
    so that some are alike."""
    names = [f"t{i}" for i in range(int(rng.integers(2, 9)))]
    names += [n for n in (PositionForce.name, "bleed_land", "seal_turn") if rng.random() < 0.5]
    bases = [rng.normal(size=N) for _ in range(3)]
    cands, refused = [], {}
    for n in names:
        shape = bases[int(rng.integers(3))] + rng.normal(scale=rng.choice([0.05, 1.0]), size=N)
        lr = float(rng.choice([1e3, 1e4, 1e5])) * float(rng.uniform(0.5, 2))
        p = float(rng.choice([0.001, 0.001, 0.02, 0.5]))
        peak = float(rng.choice([50.0, 50.0, 0.1]))  # 0.1: too small to matter
        cands.append(_candidate(n, lr, p, shape, peak))
        if rng.random() < 0.3:
            refused[n] = "refused by a rule that does not read the gain"
        Fake.table[n] = float(rng.choice([-0.3, 0.05, 0.3, 0.9, 0.98]))
    return cands, refused


def _outcome(
    cands: list[Candidate],
    scored: dict[str, tuple[float, str]],
    refused: dict[str, str],
    s: Settings,
    shapes: list[tuple[str, np.ndarray]],
) -> tuple[str | None, list[str], dict[str, list[str]], dict[str, tuple[float, str]]]:
    screened = sorted(
        (c for c in cands if c.p_value < s.screen_alpha and c.lr > 0), key=lambda c: -c.lr
    )
    reasons = {c.name: why_not(c, scored, s, 1.0, shapes, None, refused) for c in cands}
    best, pool, alike = decide(cands, screened, scored, reasons, s)
    if best is None:
        return None, [], alike, {}
    # What the search reads of the round: the claim, `outranked` (after a calibration),
    # the pairs it cannot tell apart, and the gains of the claimed and of those pairs.
    outranked = [c.name for c in pool if c is not best] if best.name in CALIBRATIONS else []
    outranked = [n for n in outranked if n not in CALIBRATIONS]
    read = {n: scored[n] for n in [best.name, *alike]}
    return best.name, outranked, alike, read


def _scored(
    top: list[Candidate],
    s: Settings,
    shapes: list[tuple[str, np.ndarray]],
    refused: dict[str, str],
    folds: list[str],
) -> dict[str, tuple[float, str]]:
    """Round 1's held-out scores of `top` (HeldOut is the Fake: no model, no workers)."""
    judge = claim_rules.Judge(1, s, 1.0, shapes, None, refused, None, folds, _silent, None)  # type: ignore[arg-type]
    return judge.score_heldout(top)


def _silent(stage: str, fraction: float) -> None:
    pass


@pytest.mark.parametrize("joining", [False, True])
def test_scoring_only_what_decides_decides_as_scoring_all(
    monkeypatch: pytest.MonkeyPatch, joining: bool
) -> None:
    monkeypatch.setattr(claim_rules, "HeldOut", Fake)
    s = Settings()
    rng = np.random.default_rng(44 + joining)
    claims = saved = total = guessed = wasted = 0
    for _ in range(400):
        Fake.table, Fake.asked, Fake.prefetched = {}, [], []
        cands, refused = _round(rng, s)
        shapes = [("claimed", rng.normal(size=N))] if joining else []
        screened = sorted(
            (c for c in cands if c.p_value < s.screen_alpha and c.lr > 0), key=lambda c: -c.lr
        )
        top = [c for c in screened if c.p_value < s.alpha]
        every = {c.name: (Fake.table[c.name], f"folds of {c.name}") for c in top}
        lazy = _scored(top, s, shapes, refused, ["fold"])
        assert len(Fake.asked) == len(set(Fake.asked)), "a candidate scored twice"
        # Refitted ahead only among those scoring all would refit, and mostly then asked.
        assert set(Fake.prefetched) <= set(every)
        guessed += len(Fake.prefetched)
        wasted += len(set(Fake.prefetched) - set(Fake.asked))
        assert set(lazy) <= set(every) and all(lazy[n] == every[n] for n in lazy)
        want = _outcome(cands, every, refused, s, shapes)
        got = _outcome(cands, lazy, refused, s, shapes)
        assert got == want, (want, got, {c.name: (c.lr, c.p_value) for c in cands}, refused)
        claims += want[0] is not None
        saved += len(every) - len(lazy)
        total += len(every)
    # The rounds drawn claim something in some and save scoring in many.
    assert 50 < claims < 400 and saved > total / 4, (claims, saved, total)
    assert wasted < guessed / 4, (wasted, guessed)


def test_a_real_effect_below_refused_candidates_is_scored_and_claimed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The three candidates with the largest LR are refused by other rules (not
    physical, spread delays, ...): they are not scored, and the real one below them is
    scored and claimed; the open set, below it, is not scored."""
    monkeypatch.setattr(claim_rules, "HeldOut", Fake)
    s = Settings()
    rng = np.random.default_rng(3)
    real = rng.normal(size=N)
    cands = [_candidate(f"t{i}", 1e6 - i, 0.001, rng.normal(size=N), 50.0) for i in range(3)]
    cands += [_candidate("real", 1e4, 0.001, real, 50.0)]
    cands += [_candidate(PositionForce.name, 9e3, 0.001, rng.normal(size=N), 50.0)]
    refused = {f"t{i}": "not physical" for i in range(3)}
    Fake.table = {c.name: 0.9 for c in cands}
    Fake.asked = []
    lazy = _scored(cands, s, [], refused, ["fold"])
    assert Fake.asked == ["real"]
    assert _outcome(cands, lazy, refused, s, [])[0] == "real"
    # Its gain too small: nothing named is claimable, so the open set is scored (and
    # claimed, as scoring all would).
    Fake.table["real"], Fake.asked = 0.05, []
    lazy = _scored(cands, s, [], refused, ["fold"])
    assert Fake.asked == ["real", PositionForce.name]
    assert _outcome(cands, lazy, refused, s, [])[0] == PositionForce.name


def test_a_round_with_nothing_claimable_scores_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """A clean sweep's round: every candidate refused by other rules, none scored, none
    claimed; with no held-out split, every p < alpha candidate gets the split's 0."""
    monkeypatch.setattr(claim_rules, "HeldOut", Fake)
    s = Settings()
    rng = np.random.default_rng(5)
    cands = [_candidate(f"t{i}", 1e4 * (i + 1), 0.001, rng.normal(size=N), 50.0) for i in range(4)]
    refused = {c.name: "its parameters stay at their off values" for c in cands}
    Fake.table, Fake.asked = {c.name: 0.9 for c in cands}, []
    lazy = _scored(cands, s, [], refused, ["fold"])
    assert Fake.asked == [] and lazy == {}
    assert _outcome(cands, lazy, refused, s, [])[0] is None
    none = _scored(cands, s, [], {}, [])
    assert none == {c.name: (0.0, "no held-out split") for c in cands}
    assert math.isnan(lazy.get("t0", (math.nan, ""))[0])
