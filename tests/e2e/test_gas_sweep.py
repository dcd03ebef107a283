"""A velocity-planned sweep on the simulated rig, reported: every planned velocity measured
(no extrapolation), damping force with the measured gas force removed, raw on request."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from shockdyno.cli import main
from shockdyno.fit.result import FitResult
from shockdyno.model import default_spec_path, load_spec
from shockdyno.record import open_recording
from shockdyno.report.clickchart import click_chart, spec_static_force_n
from shockdyno.report.gas import with_gas_force

REPO = Path(__file__).resolve().parents[2]
CLICKS = (6, 18)


def chart_rows(report_dir: Path) -> list[dict[str, str]]:
    return list(csv.DictReader((report_dir / "click_chart.csv").read_text().splitlines()))


@pytest.fixture(scope="module")
def planned(tmp_path_factory: pytest.TempPathFactory) -> Path:
    rec = tmp_path_factory.mktemp("gas") / "planned.mcap"
    code = main(["sweep", "--rig", str(REPO / "rigs" / "sim.toml"), "--start-sim",
                 "--speed", "50", "--clicks", ",".join(map(str, CLICKS)),
                 "--velocities-mm-s", "50,300", "--amplitude-mm", "20", "--cycles", "2",
                 "--warmup-cycles", "1", "-o", str(rec)])  # fmt: skip
    assert code == 0
    return rec


@pytest.fixture(scope="module")
def report(planned: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`report PLANNED -o DIR`, no other option: made once, read by the two tests that check
    that page (each made its own)."""
    out = tmp_path_factory.mktemp("gas-report") / "report"
    assert main(["report", str(planned), "-o", str(out)]) == 0
    return out


def test_every_planned_velocity_is_measured_not_extrapolated(report: Path) -> None:
    rows = [r for r in chart_rows(report) if r["source"] == "measured"]
    assert len(rows) == 2 * 12
    for r in rows:  # 300 mm/s is planned; every standard velocity lies under it
        assert r["extrapolated"] == "0", r
        assert r["gas_removed"] == "1"
    page = (report / "index.html").read_text(encoding="utf-8")
    assert "gas force removed: 231 N measured at mid-stroke at rest" in page


def test_damping_force_is_the_models_and_raw_differs_by_the_measured_gas(
    planned: Path, report: Path, tmp_path: Path
) -> None:
    tests = open_recording(planned).load_all()
    truth = spec_static_force_n(load_spec())
    assert {t.meta.gas_force_source for t in tests} == {"measured"}
    for t in tests:
        assert t.meta.gas_force_n == pytest.approx(truth, abs=1.0)
    info = tmp_path / "info.json"
    assert main(["info", str(planned), "--json", str(info)]) == 0
    rows = json.loads(info.read_text())["tests"]
    assert [(r["gas_force_n"], r["gas_force_source"]) for r in rows] == [
        (t.meta.gas_force_n, "measured") for t in tests
    ]
    fit = FitResult.from_spec(default_spec_path(), CLICKS)  # the simulated damper itself
    damping = click_chart(tests, fit)
    for c in CLICKS:
        reb = damping.measured[(c, 0)][-0.025]
        assert not reb.extrapolated
        # The branch averages the stroke where the gas spring differs from mid-stroke (a
        # few N); the model is at x = 0: both are damping alone.
        assert reb.force_n == pytest.approx(damping.model[(c, 0)][-0.025], abs=12.0), c
    raw_dir = tmp_path / "raw"
    assert main(["report", str(planned), "-o", str(raw_dir), "--raw-force"]) == 0
    raw = {(r["clicks"], r["velocity_m_s"], r["source"]): r for r in chart_rows(raw_dir)}
    for r in chart_rows(report):
        if not r["force_n"]:
            continue
        other = raw[(r["clicks"], r["velocity_m_s"], r["source"])]
        assert other["gas_removed"] == "0" and other["gas_force_n"] == ""
        gas = float(r["gas_force_n"])
        assert gas == pytest.approx(truth, abs=1.0)
        assert float(other["force_n"]) - float(r["force_n"]) == pytest.approx(gas, abs=0.011)


def test_a_shut_bleed_with_aerated_oil_lends_its_tests_another_clicks_gas_force(
    tmp_path: Path,
) -> None:
    rec = tmp_path / "aerated.mcap"
    code = main(["sweep", "--rig", str(REPO / "rigs" / "sim.toml"), "--start-sim",
                 "--speed", "50", "--clicks", "0,12", "--freq", "1", "--cycles", "2",
                 "--warmup-cycles", "1", "--scenario",
                 str(REPO / "sim" / "scenarios" / "aerated-oil.toml"), "-o", str(rec)])  # fmt: skip
    assert code == 0
    recording = open_recording(rec)
    # At click 0 oil is trapped behind the shut valves: the two rests are hundreds of N
    # apart, the measurement is refused and click 0's test has none of its own.
    events = [m for _, kind, m in recording.events if kind == "gas_force"]
    assert len(events) == 2 and "not used" in events[0] and "not used" not in events[1]
    metas = recording.tests
    assert metas[0].gas_force_n is None
    truth = spec_static_force_n(load_spec())
    assert metas[1].gas_force_n == pytest.approx(truth, abs=1.0)
    lent = with_gas_force(recording.load_all())[0].meta
    assert (lent.gas_force_n, lent.gas_force_source) == (metas[1].gas_force_n, "measured")
