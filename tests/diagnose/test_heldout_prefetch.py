"""HeldOut.prefetch (diagnose/candidates.py): candidates refitted on the folds ahead of being
scored give the scores of asking for them alone, each (candidate, fold) refitted once, and
the baseline's folds once, in the first map."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from shockdyno.diagnose import candidates as cand_mod
from shockdyno.diagnose.candidates import Candidate, FoldOutcome, HeldOut
from shockdyno.diagnose.fitting import Fitted
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec

SPEC = load_spec(None)


class Fold:
    def __init__(self, label: str) -> None:
        self.label = label
        self.halves = None


def _candidate(name: str) -> Candidate:
    fitted = Fitted(DamperModel(SPEC), (), {}, {}, np.zeros(0), np.zeros(0))
    return Candidate(name, fitted, 1e4, 0.001, 50.0, 50.0, np.ones(4))


@pytest.fixture
def refits(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, str]]:
    """Each fold refit asked for ((fold, candidate or "baseline")), with outcomes and a
    judge that depend on both, so a mixed-up cache would show."""
    asked: list[tuple[str, str]] = []

    def fold_task(shared: Any, item: tuple[Fold, Candidate | None]) -> Any:
        fold, cand = item
        asked.append((fold.label, cand.name if cand is not None else "baseline"))
        if cand is None:
            return np.full(2, float(len(fold.label)))
        acts = np.ones(2, dtype=bool)
        structure = np.array([len(cand.name), len(fold.label)], dtype=float)
        return FoldOutcome(fold.label, False, False, acts, True, structure)

    def judge(outcomes: Any, whole: Any, halves: Any) -> tuple[float, str]:
        pairs = zip(outcomes, whole, strict=True)
        parts = [f"{o.label}:{o.structure.tolist()}:{w.tolist()}" for o, w in pairs]
        return float(sum(o.structure[0] for o in outcomes)), "; ".join(parts)

    monkeypatch.setattr(cand_mod, "_fold_task", fold_task)
    monkeypatch.setattr(cand_mod, "judge", judge)
    return asked


def test_prefetched_candidates_score_as_asked_alone(refits: list[tuple[str, str]]) -> None:
    folds = [Fold("f1"), Fold("fold2")]
    a, bb, ccc = _candidate("a"), _candidate("bb"), _candidate("ccc")
    alone = HeldOut(folds, None, 3)  # type: ignore[arg-type]
    want = {c.name: alone.gains([c])[0] for c in (a, bb, ccc)}
    refits.clear()

    held = HeldOut(folds, None, 3)  # type: ignore[arg-type]
    held.prefetch([a, bb])
    assert refits == [
        ("f1", "baseline"),
        ("fold2", "baseline"),
        ("f1", "a"),
        ("fold2", "a"),
        ("f1", "bb"),
        ("fold2", "bb"),
    ]
    held.prefetch([a])  # refitted already: nothing asked
    assert held.gains([bb]) == [want["bb"]] and held.gains([a]) == [want["a"]]
    assert len(refits) == 6
    assert held.gains([ccc, a]) == [want["ccc"], want["a"]]
    assert refits[6:] == [("f1", "ccc"), ("fold2", "ccc")]
