"""Physics outside the library on the held-out plant (benchmarks/holdout: written apart
from the library), diagnosed as a user would (CSV import, then `diagnose`): rod-guide
friction from a side load (benchmarks/unnamed/effects.py), which no term has, is located,
described and modelled by a discovered term, with no named physics claimed for it; the
clean plant gets no discovered term. benchmarks/bench_unnamed.py runs every effect."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

from inprocess import cli  # noqa: E402
from unnamed.effects import Unnamed, record_sweep  # noqa: E402

pytestmark = [pytest.mark.timeout(900), pytest.mark.slow]
CLICKS = (2, 10, 20)
SCORED = ("compressibility", "cavitation", "friction", "sensor_lag", "thermal", "contact")


def _diagnosed(root: Path, extra: Unnamed, seed: int) -> dict[str, Any]:
    record_sweep(extra, root, seed=seed, clicks=CLICKS)
    rec, diag = root / "REC.mcap", root / "DIAG.json"
    for cmd in (
        ["import", str(root / "manifest.csv"), "-o", str(rec)],
        ["diagnose", str(rec), "--json", str(diag)],
    ):
        done = cli(*cmd)  # the commands a user runs, in this process (a second each to start)
        assert done.returncode == 0, done.stderr[-2000:]
    doc: dict[str, Any] = json.loads(diag.read_text())
    return doc


@pytest.fixture(scope="module")
def side_load(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    extra = Unnamed(side_n_per_m=1.2e3, side_onset_m=-0.004)
    return _diagnosed(tmp_path_factory.mktemp("sideload"), extra, seed=5)


def test_side_load_friction_is_modelled_by_a_discovered_term_and_no_named_one(
    side_load: dict[str, Any],
) -> None:
    verdict = side_load["verdict"]
    assert not set(verdict["physics"]) & set(SCORED), verdict["text"]
    left = verdict["unexplained"][0]
    assert left["x_range_m"][0] < -0.004, left  # located where the rod is extended
    term = left["term"]
    assert term["claimed"], verdict["text"]
    assert {c["family"] for c in term["coefficients"]} == {"position × friction"}, term["form"]
    assert term["heldout_gain"] >= 0.5, term["heldout_detail"]


def test_the_clean_plant_gets_no_discovered_term(tmp_path: Path) -> None:
    verdict = _diagnosed(tmp_path, Unnamed(), seed=5)["verdict"]
    claimed = [u for u in verdict["unexplained"] if (u.get("term") or {}).get("claimed")]
    assert claimed == [], verdict["text"]
