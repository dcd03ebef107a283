"""Repeatability: per-cycle values against known truth (a periodic model test, injected
load-cell noise, an imposed drift), and the drift warning on the page and the terminal."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from report_helpers import make_test, write_recording
from shockdyno.cli import main
from shockdyno.record.types import TestData
from shockdyno.report import clickchart, repeatability


def _with_force(test: TestData, force: np.ndarray) -> TestData:
    return replace(test, force=force)


def _drifting(test: TestData, share: float, noise_n: float, seed: int) -> TestData:
    """The model's force scaled from 1 to 1 + share over the measured window, plus noise."""
    lo, hi = test.meta.measured_start_s, test.meta.measured_end_s
    assert lo is not None and hi is not None
    ramp = 1.0 + share * np.clip((test.t - lo) / (hi - lo), 0.0, 1.0)
    rng = np.random.default_rng(seed)
    return _with_force(test, test.force * ramp + rng.normal(0.0, noise_n, test.t.size))


def test_a_periodic_test_has_no_cycle_scatter_and_its_mean_is_the_chart_value() -> None:
    # 1 Hz at 1 kHz: every cycle is the same 1000 samples of the model, so each cycle's
    # reading is the same number and their mean is what the click chart shows.
    test = make_test(0, 10, 1.0, cycles=4)
    targets = clickchart.signed_velocities()
    cycles = repeatability.test_cycles(test, targets)
    assert cycles is not None and cycles.n_cycles == 4
    # the cycles read the force as given (raw here); the scatter of damping force is the same
    chart = clickchart.click_chart([test], raw_force=True)
    reached = [t for t in targets if not chart.measured[(10, 0)][t].extrapolated]
    assert len(reached) == 8  # 1 Hz x 30 mm peaks at 0.19 m/s: 200 and 300 are not met
    for t in targets:
        r = cycles.readings[t]
        if t not in reached:  # no crossing: no per-cycle value, never an extrapolated one
            assert np.all(np.isnan(r)), t
            continue
        assert np.ptp(r) < 1e-6 * max(1.0, abs(float(np.mean(r))))
        assert float(np.mean(r)) == pytest.approx(chart.measured[(10, 0)][t].force_n, abs=1e-6)
    assert np.ptp(cycles.peak_compression_n) < 1e-6


def test_cycle_scatter_matches_the_injected_load_cell_noise() -> None:
    # A reading interpolates two samples with weights (1 - w, w), w uniform: its noise SD
    # is σ·√(2/3); a cycle averages its two crossings of the velocity: σ/√3 per cycle.
    sigma = 5.0
    clean = make_test(0, 10, 2.0, cycles=20)
    rng = np.random.default_rng(3)
    test = _with_force(clean, clean.force + rng.normal(0.0, sigma, clean.t.size))
    cycles = repeatability.sweep_cycles([test])
    scatter = repeatability.chart_scatter(cycles, clickchart.signed_velocities())
    sds = [s.cycle_sd_n for s in scatter[(10, 0)].values()]
    assert float(np.mean(sds)) == pytest.approx(sigma / math.sqrt(3), rel=0.2)
    s = scatter[(10, 0)][0.1]
    assert s.n_tests == 1 and s.n_cycles == 20
    assert s.sd_of_mean_n == pytest.approx(s.cycle_sd_n / math.sqrt(20))
    # Peaks: the max of ~40 noisy samples near the top, so about σ, not zero.
    assert 0.5 * sigma < repeatability.band_sd(cycles[0].peak_compression_n) < 2 * sigma


def test_test_to_test_scatter_counts_when_a_click_has_several_tests() -> None:
    a = make_test(0, 10, 1.0, cycles=4)
    b = make_test(1, 10, 1.0, cycles=4, t0=10.0)
    b = _with_force(b, b.force + 30.0)
    cycles = repeatability.sweep_cycles([a, b])
    s = repeatability.chart_scatter(cycles, (0.1,))[(10, 0)][0.1]
    # Cycles are identical within each test; the two tests differ by 30 N.
    assert s.n_tests == 2 and s.cycle_sd_n < 1e-6
    assert s.test_sd_n == pytest.approx(30.0 / math.sqrt(2))
    assert s.sd_of_mean_n == pytest.approx(15.0)


def test_drift_is_found_with_its_size_and_a_small_one_is_not() -> None:
    base = make_test(0, 10, 2.0, cycles=8)
    found = repeatability.drifts(repeatability.sweep_cycles([_drifting(base, 0.06, 2.0, 1)]))
    assert {d.direction for d in found} == {"compression", "rebound"}
    for d in found:
        # The line runs through the cycles' midpoints: 7/8 of the 6 % ramp between them.
        assert d.change_share == pytest.approx(0.06 * 7 / 8, rel=0.15)
        assert "temperature" in d.text() and "mount" in d.text()
    # 1 % over the test is resolved (noise 2 N on ~1000 N) but under the practical floor.
    small = repeatability.sweep_cycles([_drifting(base, 0.01, 2.0, 2)])
    assert repeatability.drifts(small) == []
    steady = repeatability.sweep_cycles([_drifting(base, 0.0, 2.0, 3)])
    assert repeatability.drifts(steady) == []


def test_report_shows_the_drift_and_prints_one_warning_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tests = [_drifting(make_test(0, 10, 2.0, cycles=6), 0.05, 2.0, 4),
             _drifting(make_test(1, 10, 1.0, cycles=4, t0=10.0), 0.0, 2.0, 5)]  # fmt: skip
    rec = write_recording(tmp_path / "drift.mcap", tests, {"damper_id": "drift"})
    out = tmp_path / "report"
    assert main(["report", str(rec), "-o", str(out)]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert len(err) == 2  # compression and rebound of test 0, one line each
    assert all(line.startswith("report: warning: test 0 (clicks 10") for line in err)
    html = (out / "index.html").read_text(encoding="utf-8")
    assert html.count('<p class="warn">Drift: test 0') == 2
    assert "±2 SD" in html


def test_a_test_without_a_measured_window_is_cut_into_its_whole_cycles() -> None:
    # Older or hand-made recordings store no window: the whole record is measured (as
    # TestData.measured() has it), 1 warm-up + 3 cycles at 1.5 Hz, and no part cycle.
    test = make_test(0, 10, 1.5, cycles=3)
    bare = replace(test, meta=replace(test.meta, measured_start_s=None, measured_end_s=None))
    bounds = repeatability.cycle_bounds(bare)
    assert len(bounds) == 4
    assert bounds[-1][1] <= float(bare.t[-1]) + 1e-3 + 1e-9
    imported = replace(bare, meta=replace(bare.meta, motion="imported"))
    assert repeatability.cycle_bounds(imported) == []  # no period to cut by
