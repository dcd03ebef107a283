"""A damper's history on the simulated rig: three sweeps of one damper (`sweep --damper-id`),
the third after a rebuild that opened its compression bleed 1.5x (a spec with that bleed
area: the known truth). `fit` adds the first two, `batch fit` the third, `diagnose` one;
`shockdyno history` shows the change where it is, and only there."""

from __future__ import annotations

import importlib.util
import json
import re
import sys
from pathlib import Path
from typing import Any

import pytest

from shockdyno.cli import main
from shockdyno.model.spec import default_spec_path
from shockdyno.simrig import start_sim_rig

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "rigs" / "sim.toml"
AREA_LINE = "area_open_m2 = 1.2e-5 "  # [bleed.compression] of the shipped spec
DAMPER = "S46-0421"
pytestmark = pytest.mark.timeout(400)  # three sweeps, fits, a batch: 17 s on an idle machine


def _helpers() -> Any:
    spec = importlib.util.spec_from_file_location(
        "stop_helpers", REPO / "tests/e2e/stop_helpers.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("stop_helpers", module)
    spec.loader.exec_module(module)
    return module


def _sweep(folder: Path, name: str, spec: Path | None, seed: int) -> Path:
    """`shockdyno sweep` of the damper on a simulated rig running `spec`."""
    out = folder / f"{name}.mcap"
    with start_sim_rig(SIM_RIG, speed=40, seed=seed, spec_path=spec) as sim:
        rig = _helpers().rig_file_for(sim, folder)
        args = ["sweep", "--rig", str(rig), "--clicks", "10,21", "--freq", "1.5", "--cycles",
                "3", "--warmup-cycles", "1", "--damper-id", DAMPER, "--operator", "jd"]  # fmt: skip
        assert main([*args, "-o", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def shop(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("shop")
    rebuilt = d / "rebuilt.toml"
    text = default_spec_path().read_text()
    assert text.count(AREA_LINE) == 1
    rebuilt.write_text(text.replace(AREA_LINE, "area_open_m2 = 1.8e-5 "))
    db = d / "history.sqlite"
    recs = {
        "received": _sweep(d, "received", None, seed=1),
        "retest": _sweep(d, "retest", None, seed=2),
        "rebuilt": _sweep(d, "rebuilt", rebuilt, seed=3),
    }
    for name in ("received", "retest"):
        args = ["fit", str(recs[name]), "--json", str(d / f"{name}.fit.json"), "--terms", "none"]
        assert main([*args, "--history", str(db)]) == 0
    batch = ["batch", "fit", str(recs["rebuilt"]), "--out", str(d / "batch"), "--workers", "1",
             "--terms", "none", "--history", str(db)]  # fmt: skip
    assert main(batch) == 0
    diag = ["diagnose", str(recs["rebuilt"]), "--json", str(d / "rebuilt.diag.json"),
            "--workers", "1", "--history", str(db)]  # fmt: skip
    assert main(diag) == 0
    return {**recs, "db": db, "folder": d}


def test_history_shows_the_rebuilds_bleed_change_and_nothing_else(
    shop: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    js = shop["folder"] / "history.json"
    png = shop["folder"] / "history.png"
    args = ["history", DAMPER, "--history", str(shop["db"]), "--json", str(js), "--plot", str(png)]
    assert main(args) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert f"history of damper {DAMPER}: 3 recordings" in out
    assert "received.mcap" in out and "rebuilt.mcap" in out and " jd " in out
    changed = re.findall(r"(A_b[ct] at \d+ clicks): [^()]*\(([+-]\d+) %, changed\)", out)
    # Known truth: the rebuilt spec's compression bleed is 1.5x at every open click.
    assert sorted(changed) == [("A_bc at 10 clicks", "+50"), ("A_bc at 21 clicks", "+50")]
    assert "friction_n" not in out.split("changed from the first")[1]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    doc = json.loads(js.read_text())
    visits = doc["visits"]
    assert [Path(v["recording"]["file"]).stem for v in visits] == ["received", "retest", "rebuilt"]
    assert [v["recording"]["damper_id"] for v in visits] == [DAMPER] * 3

    def a_bc(visit: dict[str, Any], clicks: int) -> float:
        (fit,) = [r for r in visit["results"] if r["kind"] == "fit"]
        (area,) = [a for a in fit["areas"] if a["clicks"] == clicks]
        return float(area["a_bc_m2"])

    for clicks in (10, 21):
        first, again, rebuilt = (a_bc(v, clicks) for v in visits)
        assert again == pytest.approx(first, rel=0.02)  # the re-test: the same damper
        assert rebuilt / first == pytest.approx(1.5, rel=0.03)  # the rebuild, as built
    # batch fit filled the third, diagnose added its diagnosis beside the fit
    assert [r["kind"] for r in visits[2]["results"]] == ["fit", "diagnose"]
    assert visits[2]["results"][0]["result_file"].endswith("batch/rebuilt.fit.json")
    gas = [v["recording"]["gas"][0] for v in visits]
    assert all(g["source"] == "measured" and 225 < g["gas_force_n"] < 237 for g in gas)


def test_fitting_a_recording_again_replaces_its_result(
    shop: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    db = shop["folder"] / "again.sqlite"
    fit = ["fit", str(shop["received"]), "--json", str(shop["folder"] / "again.fit.json"),
           "--terms", "none", "--history", str(db), "--force"]  # fmt: skip
    assert main(fit) == 0 and main(fit) == 0
    capsys.readouterr()
    assert main(["history", DAMPER, "--history", str(db), "--json", "-"]) == 0
    visits = json.loads(capsys.readouterr().out)["visits"]
    assert len(visits) == 1 and [r["kind"] for r in visits[0]["results"]] == ["fit"]
    assert main([*fit[:-1], "--no-history", "--force", "--terms", "sensor_lag"]) == 0
    capsys.readouterr()
    assert main(["history", DAMPER, "--history", str(db), "--json", "-"]) == 0
    assert len(json.loads(capsys.readouterr().out)["visits"][0]["results"]) == 1
