"""Gas force of recordings without a measured one: the reversal estimate against the model's
known force at rest, the median that outvotes a shut bleed, old files; and the click chart
with the gas force removed against the model's damping alone."""

from __future__ import annotations

import csv
import io
import math
from dataclasses import replace
from pathlib import Path

import pytest

from report_helpers import make_test, spec
from shockdyno.fit.result import FitResult
from shockdyno.model import default_spec_path
from shockdyno.record import open_recording
from shockdyno.report.clickchart import click_chart, spec_static_force_n, to_csv
from shockdyno.report.gas import (
    damping_force,
    describe,
    remove_gas,
    reversal_estimate,
    with_gas_force,
)

REPO = Path(__file__).resolve().parents[2]
OLD_RECORDINGS = [
    REPO / "recordings" / "examples" / "example.mcap",  # the shipped example (simulated S46)
    REPO / "tests" / "record" / "fixtures" / "format1_example.mcap",  # format 1, 0.1.0
]


def gas_truth() -> float:
    """The model's force at rest at mid-stroke: (p_gas - p_atm) A_rod = 230.7 N."""
    return spec_static_force_n(spec())


def test_reversal_estimate_is_the_gas_force_at_mid_stroke() -> None:
    # Model tests (no noise): the isothermal gas spring's convexity puts the mean of the two
    # ends p/(1 - (A_rod A / V0)^2) - p above mid-stroke: 1.34 N at 30 mm, seen at 0.5 and
    # 1 Hz; at 1.5 Hz up to 2.7 N (the reversal read off the filtered velocity).
    for clicks, f in ((12, 1.0), (6, 0.5)):
        est = reversal_estimate(make_test(0, clicks, f))
        assert est == pytest.approx(gas_truth() + 1.34, abs=0.05), (clicks, f)
    assert reversal_estimate(make_test(0, 21, 1.5)) == pytest.approx(gas_truth(), abs=3.0)


def test_a_shut_bleed_is_outvoted_by_the_other_clicks() -> None:
    shut = make_test(0, 0, 1.5)
    # The valves' preload makes the force jump at the reversal: no gas force there.
    assert abs(reversal_estimate(shut) - gas_truth()) > 50
    tests = with_gas_force([shut, make_test(1, 9, 1.5), make_test(2, 21, 1.5)])
    for t in tests:
        assert t.meta.gas_force_source == "estimated"
        assert t.meta.gas_force_n == pytest.approx(gas_truth(), abs=3.0)
    # Removing it leaves the damping force: the force minus the gas force, sample by sample.
    assert damping_force(tests[1]) == pytest.approx(tests[1].force - tests[1].meta.gas_force_n)
    assert describe(tests) == "gas force removed: 233 N estimated from the sine's reversals"


def test_half_shut_bleeds_do_not_pull_the_estimate() -> None:
    """One shut-bleed test against one open: a median of the two midpoints would sit
    between them (a review's sweep of clicks 0 and 21 read 132 N against 231 N); the test
    whose reversal ends are closest (the bleed lets the force relax) gives the estimate."""
    shut, open_ = make_test(0, 0, 1.5), make_test(1, 21, 1.5)
    assert abs(reversal_estimate(shut) - gas_truth()) > 20
    for t in with_gas_force([shut, open_]):
        assert t.meta.gas_force_n == pytest.approx(gas_truth(), abs=3.0)


def test_a_measured_gas_force_is_kept_and_lent_to_a_click_without_one() -> None:
    a = make_test(0, 9, 1.0)
    a = replace(a, meta=replace(a.meta, gas_force_n=200.0, gas_force_source="measured"))
    b = make_test(1, 0, 1.0)  # its own measurement unusable (shut bleed): none stored
    got = with_gas_force([a, b])
    assert [(t.meta.gas_force_n, t.meta.gas_force_source) for t in got] == [
        (200.0, "measured"),
        (200.0, "measured"),
    ]
    assert remove_gas([a])[0].force == pytest.approx(a.force - 200.0)


@pytest.mark.parametrize("path", OLD_RECORDINGS, ids=lambda p: p.name)
def test_old_recordings_read_and_get_an_estimated_gas_force(path: Path) -> None:
    tests = open_recording(path).load_all()
    assert tests and all(t.meta.gas_force_n is None for t in tests)  # older than the field
    for t in with_gas_force(tests):
        assert t.meta.gas_force_source == "estimated"
        # Recorded on the simulated rig with the shipped spec (noise and the convexity).
        assert t.meta.gas_force_n == pytest.approx(gas_truth(), abs=3.0)


def test_click_chart_without_the_gas_force_is_the_models_damping() -> None:
    tests = [make_test(k, c, 1.0) for k, c in enumerate((0, 12, 21))]
    fit = FitResult.from_spec(default_spec_path(), [0, 12, 21])
    damping = click_chart(tests, fit)
    raw = click_chart(tests, fit, raw_force=True)
    gas = with_gas_force(tests)[0].meta.gas_force_n
    assert gas is not None
    assert damping.gas_note.startswith("gas force removed: 232 ± 4 N estimated")
    for key in ((0, 0), (12, 0), (21, 0)):
        # Raw and damping differ by the gas force, measured and model alike.
        for v in damping.velocities_m_s:
            if math.isfinite(raw.measured[key][v].force_n):
                assert raw.measured[key][v].force_n - damping.measured[key][v].force_n == (
                    pytest.approx(gas, abs=1e-6)
                )
            assert raw.model[key][v] - damping.model[key][v] == pytest.approx(gas_truth(), abs=1e-6)
        reb = damping.measured[key][-0.025].force_n
        # Rebound at 25 mm/s: damping only. The chart read +71 N at click 9 and
        # +152 N at click 21 in rebound; now both sides agree on a rebound force <= 0.
        assert reb == pytest.approx(damping.model[key][-0.025], abs=10.0), key
        assert reb < 5.0
    rows = list(csv.DictReader(io.StringIO(to_csv(damping))))
    assert {r["gas_removed"] for r in rows} == {"1"}
    for r in rows:
        want = gas_truth() if r["source"] == "model" else gas
        assert float(r["gas_force_n"]) == pytest.approx(want, abs=0.006)
    assert {r["gas_removed"] for r in csv.DictReader(io.StringIO(to_csv(raw)))} == {"0"}
