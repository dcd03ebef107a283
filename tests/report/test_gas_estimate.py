"""The estimated gas force of an imported recording (issue 47.1), against the known truth of
the simulated rig: a sweep of the simulated S46 measures its gas force at mid-stroke; the
same sweep exported, stripped of that measurement, thinned to 333 Hz and imported again
must get an estimate within its stated uncertainty of it, bounded, and a shut bleed alone
must be refused with the sample rate named, not removed as -291 N; the user gives it."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from report_helpers import make_test, spec
from shockdyno.cli import main
from shockdyno.model.spec import default_spec_path, load_spec
from shockdyno.record import open_recording
from shockdyno.report.clickchart import spec_static_force_n
from shockdyno.report.gas import (
    ALL_SETTINGS,
    Charge,
    charge_limit,
    gas_forces,
    limit_for,
    parse_given,
)

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "rigs" / "sim.toml"
CONVEXITY_N = 1.34  # the mean of the two reversals sits above mid-stroke (report/gas.py)


def _thinned(src: Path, out: Path, step: int, clicks: tuple[int, ...]) -> Path:
    """An exported recording as another dyno would hand it over: every `step`-th sample,
    no gas force column, only these clicks; then imported (the CLI both ways)."""
    folder = out.with_suffix("")
    folder.mkdir()
    rows = list(csv.DictReader((src / "manifest.csv").read_text().splitlines()))
    keep = [r for r in rows if int(r["clicks"]) in clicks]
    with (folder / "manifest.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["file", "clicks", "frequency_hz", "amplitude_m", "gas_clicks"])
        for r in keep:
            w.writerow([r["file"], r["clicks"], r["frequency_hz"], r["amplitude_m"], "0"])
            lines = (src / r["file"]).read_text().splitlines()
            data = [ln for ln in lines if not ln.startswith("#")]
            (folder / r["file"]).write_text("\n".join([data[0], *data[1::step]]) + "\n")
    assert main(["import", str(folder / "manifest.csv"), "-o", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def sweep(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A sweep of the simulated rig (clicks 0 and 21, 1 Hz x 30 mm) with its gas force
    measured at mid-stroke, and its imports thinned to 333 Hz: both clicks, click 0 alone."""
    d = tmp_path_factory.mktemp("gas")
    rec = d / "sweep.mcap"
    args = ["sweep", "--rig", str(SIM_RIG), "--start-sim", "--speed", "40", "--seed", "3",
            "--clicks", "0,21", "--freq", "1", "--cycles", "4", "--warmup-cycles", "1"]  # fmt: skip
    assert main([*args, "-o", str(rec)]) == 0
    assert main(["export", str(rec), "--csv", str(d / "csv")]) == 0
    return {
        "sweep": rec,
        "both": _thinned(d / "csv", d / "both333.mcap", 3, (0, 21)),
        "shut": _thinned(d / "csv", d / "shut333.mcap", 3, (0,)),
    }


def _measured(rec: Path) -> float:
    """The rig's measurements at mid-stroke (one at the start, one after the click change)."""
    values = [t.meta.gas_force_n for t in open_recording(rec).load_all()]
    assert all(v is not None for v in values) and np.ptp(values) < 2.0
    return float(np.median(values))


def test_the_estimate_at_333_hz_is_the_rigs_measured_gas_force_within_its_sigma(
    sweep: dict[str, Path],
) -> None:
    truth = _measured(sweep["sweep"])
    assert truth == pytest.approx(spec_static_force_n(load_spec()), abs=3.0)  # the rig's own
    tests = open_recording(sweep["both"]).load_all()
    assert all(t.meta.gas_force_n is None for t in tests)
    assert all(t.meta.sample_rate_hz == pytest.approx(1000 / 3, rel=1e-3) for t in tests)
    (got,) = gas_forces(tests, limit=limit_for(tests)).values()
    assert got.source == "estimated" and got.value_n is not None and not got.rate_dependent
    assert 0 < got.sd_n < 20
    assert abs(got.value_n - (truth + CONVEXITY_N)) < 3 * got.sd_n, (got.value_n, got.sd_n)


def test_a_shut_bleed_alone_at_333_hz_is_refused_and_its_sample_rate_named(
    sweep: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tests = open_recording(sweep["shut"]).load_all()
    (got,) = gas_forces(tests, limit=limit_for(tests)).values()
    truth = _measured(sweep["sweep"]) + CONVEXITY_N
    # Never silently wrong: where the force steps between the samples either side of a
    # reversal, the estimate is wherever they fell, and it says so (flagged, its σ wide,
    # or refused); otherwise it agrees with the rig's own measurement within its σ. Which
    # of the two a run of the simulated rig gives varies: most runs seen were flagged
    # (σ 29-59 N), one full-suite run gave 219 ± 12 N, not flagged.
    estimate = got.value_n if got.value_n is not None else got.estimate_n
    assert got.rate_dependent or abs(estimate - truth) < 3 * got.sd_n, (estimate, got.sd_n)
    page = tmp_path / "page"
    assert main(["report", str(sweep["shut"]), "-o", str(page)]) == 0
    err = capsys.readouterr().err
    assert ("depends on the sample rate: at 333 Hz" in err) == got.rate_dependent
    if got.source == "refused":  # outside 0 < F <= 250 N: nothing removed, the page says so
        assert "is no gas force" in err and "not removed" in err
        html = (page / "index.html").read_text()
        assert "gas force not removed" in html and "estimated from the sine" not in html
    else:  # inside the bound by chance of where the samples fell: removed, with its σ
        assert got.value_n is not None and 0 < got.value_n <= 250.3
    # The user gives it: used as given, for the whole page.
    given = tmp_path / "given"
    assert main(["report", str(sweep["shut"]), "-o", str(given), "--gas-force-n", "231"]) == 0
    html = (given / "index.html").read_text()
    assert "gas force removed: 231 N given (--gas-force-n)" in html
    rows = list(csv.DictReader((given / "click_chart.csv").read_text().splitlines()))
    assert {float(r["gas_force_n"]) for r in rows if r["source"] == "measured"} == {231.0}


def test_the_issues_example_thinned_to_333_hz_is_refused_not_removed(tmp_path: Path) -> None:
    # The shipped click-0 example (a shut bleed) thinned to 333 Hz estimated -291 N (one
    # of its four reversals missed: its velocity was exactly zero at a sample), and the
    # page removed it; at 500 Hz it read 230 N by the luck of where the samples fell.
    src = REPO / "recordings" / "examples" / "csv"
    got = {}
    for step in (2, 3):
        rec = _thinned(src, tmp_path / f"c0_{step}.mcap", step, (0,))
        tests = open_recording(rec).load_all()
        (got[step],) = gas_forces(tests, limit=limit_for(tests)).values()
    assert got[3].source == "refused" and got[3].value_n is None
    assert got[3].estimate_n < 0 and got[3].rate_dependent  # no gas force is negative
    assert got[2].value_n == pytest.approx(230.5, abs=0.5)
    assert got[2].rate_dependent and got[2].sd_n > 100  # right by luck, and said to be


def test_compare_does_not_judge_damping_against_force_with_the_gas_in(
    sweep: dict[str, Path], tmp_path: Path
) -> None:
    # The issue: a thinned import against the same damper read "351 N (58 %) stiffer"
    # with a wrong estimate. An estimate refused (here by a spec whose 10 bar charge allows
    # at most 150 N) leaves that input's values with the gas force in: none is judged.
    low = tmp_path / "low.toml"
    text = default_spec_path().read_text()
    assert text.count("gas_pressure_pa = 1.6e6 ") == 1
    low.write_text(text.replace("gas_pressure_pa = 1.6e6 ", "gas_pressure_pa = 1.0e6 "))
    js = tmp_path / "cmp.json"
    args = ["compare", str(sweep["sweep"]), str(sweep["both"]), "--spec", str(low)]
    assert main([*args, "-o", str(tmp_path / "p"), "--json", str(js)]) == 0
    rows = json.loads(js.read_text())["rows"]
    assert rows and all(r["verdict"] == "not judged" for r in rows)
    assert all("gas force of both333 is not known" in r["text"] for r in rows)
    # Given (the rig's own measurement), every value is judged, and the same damper at
    # 333 Hz is the same damper: no difference beyond the scatter.
    js2 = tmp_path / "given.json"
    given = f"{_measured(sweep['sweep']):.1f}"
    assert (
        main([*args, "-o", str(tmp_path / "p2"), "--json", str(js2), "--gas-force-n", given]) == 0
    )
    rows = json.loads(js2.read_text())["rows"]
    assert not [r for r in rows if "gas force" in r["text"] and r["verdict"] == "not judged"]
    assert not [r for r in rows if r["verdict"] == "difference" and abs(r["diff_n"]) > 60]


def test_the_charge_bound_is_the_isothermal_gas_force_at_the_deepest_stroke() -> None:
    s = spec()
    got = charge_limit(s, 0.03, "s46")
    v0 = s.gas_piston_area_m2 * s.gas_length_m
    p = s.gas_pressure_pa * v0 / (v0 - s.rod_area_m2 * 0.03)
    assert got.max_n == pytest.approx((p - 101_325.0) * s.rod_area_m2, rel=1e-12)
    assert got.max_n == pytest.approx(250.2, abs=0.1)
    assert charge_limit(s, 0.0, "s46").max_n == pytest.approx(spec_static_force_n(s), rel=1e-9)
    assert "16.0 bar charge at +30 mm" in got.what


def test_an_estimate_above_the_charge_is_refused_and_a_given_one_wins() -> None:
    tests = [make_test(0, 12, 1.0), make_test(1, 21, 1.0)]
    (ok,) = gas_forces(tests, limit=limit_for(tests)).values()
    assert ok.source == "estimated" and ok.value_n == pytest.approx(232.0, abs=1.0)
    low = Charge(max_n=150.0, what="a 10 bar spec's charge at +30 mm")
    (refused,) = gas_forces(tests, limit=low).values()
    assert refused.source == "refused" and refused.value_n is None
    assert refused.estimate_n == pytest.approx(232.0, abs=1.0)
    text = refused.refusal()
    assert "is no gas force" in text and "allows at most 150 N" in text
    assert "--gas-force-n" in text
    (given,) = gas_forces(tests, given={ALL_SETTINGS: 240.0}, limit=low).values()
    assert (given.source, given.value_n) == ("given", 240.0)


def test_gas_force_n_is_read_as_newtons_overall_or_per_gas_setting() -> None:
    assert parse_given("231") == {ALL_SETTINGS: 231.0}
    assert parse_given("0:231,5:260.5") == {0: 231.0, 5: 260.5}
    for bad in ("-5", "0", "nan", "x", "0:abc", "-1:200"):
        with pytest.raises(Exception, match="--gas-force-n"):
            parse_given(bad)
    assert math.isclose(limit_for([make_test(0, 21, 1.0)], default_spec_path()).max_n, 250.2,
                        abs_tol=0.2)  # fmt: skip
    assert np.isfinite(limit_for([make_test(0, 21, 1.0)]).max_n)
