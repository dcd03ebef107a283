"""Sweep by target velocity on the simulated rig, then report it: the low speeds are
measured, not extrapolated."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from inprocess import cli
from shockdyno.model import load_spec
from shockdyno.record import open_recording
from shockdyno.report import summarise
from shockdyno.report.clickchart import spec_static_force_n
from shockdyno.report.gas import with_gas_force

REPO = Path(__file__).resolve().parents[2]


def test_sweep_by_velocity_then_report(tmp_path: Path) -> None:
    rec = tmp_path / "low.mcap"
    # Both commands in this process (a `shockdyno` process costs a second to start).
    sweep = ["sweep", "--rig", str(REPO / "rigs" / "sim.toml"), "--start-sim",
             "--speed", "50", "--clicks", "12", "--velocities-mm-s", "25,100",
             "--amplitude-mm", "10", "--cycles", "2", "--warmup-cycles", "1",
             "--no-gas-measure", "-o", str(rec)]  # fmt: skip
    res = cli(*sweep)
    assert res.returncode == 0, res.stderr
    tests = open_recording(rec).load_all()
    # No gas measurement: none stored, and the report estimates it from the reversals, which
    # on the simulated rig agrees with the damper's force at rest at mid-stroke (230.7 N).
    # How closely: 32 sweeps on an idle machine read 230.87 N mean, SD 1.06 N, 228.22-233.14;
    # 2 of 7 runs of this test on 2026-11-29 read 234.13 and 234.54 (where the samples fall
    # about each reversal), which a 3 N bound failed. 6 N is about 5.7 SD; an estimate pulled
    # by a shut bleed read 132 N.
    assert all(t.meta.gas_force_n is None for t in tests)
    for t in with_gas_force(tests):
        assert t.meta.gas_force_source == "estimated"
        assert t.meta.gas_force_n == pytest.approx(spec_static_force_n(load_spec()), abs=6.0)
    peaks = sorted(summarise(t).peak_compression_velocity_m_s for t in tests)
    # A peak is the largest of many noisy velocity samples, so it reads a little high; at
    # 25 mm/s that was up to 3 % in runs on a loaded machine. The fastest target is planned
    # 10 % over (run/plan.py), so that it is passed, not only touched at the peak.
    assert peaks == [pytest.approx(0.025, rel=0.05), pytest.approx(0.11, rel=0.03)]

    out = tmp_path / "report"
    res = cli("report", str(rec), "-o", str(out))
    assert res.returncode == 0, res.stderr
    rows = list(csv.DictReader((out / "click_chart.csv").read_text().splitlines()))
    extrapolated = {
        float(r["velocity_m_s"]): r["extrapolated"] == "1"
        for r in rows
        if r["source"] == "measured"
    }
    # Measured up to the fastest target, 100 mm/s, extrapolated beyond; both directions.
    for v in (0.025, 0.05, 0.1):
        assert not extrapolated[v] and not extrapolated[-v]
    for v in (0.15, 0.2, 0.3):
        assert extrapolated[v] and extrapolated[-v]
