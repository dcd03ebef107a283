"""`shockdyno compare` on sweeps of the simulated rig: a known bleed-area change is found
where it is and in its direction, the same damper twice is within the scatter; a fit as
an input; refusals and wrong files in one line."""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pytest

from inprocess import cli
from shockdyno.cli import main
from shockdyno.compare.table import DIFFERENCE, WITHIN, Row, differences
from shockdyno.fit.result import FitResult
from shockdyno.model.spec import default_spec_path
from shockdyno.record import RecordingWriter, open_recording
from shockdyno.report import clickchart
from shockdyno.run.liveview import LiveView
from shockdyno.run.plan import SweepPlan
from shockdyno.run.session import RigSession
from shockdyno.run.sweep import run_sweep
from shockdyno.simrig import start_sim_rig

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "rigs" / "sim.toml"
CLICKS = (0, 8)
CHANGED = 8  # compression bleed open 1.5x: changes every click but 0 (closed needle)
AREA_LINE = "area_open_m2 = 1.2e-5 "  # [bleed.compression] of the shipped spec


def _sweep(out: Path, seed: int, spec: Path | None = None) -> Path:
    # 2 Hz x 30 mm peaks at 0.38 m/s: every standard velocity is crossed, none extrapolated.
    plan = SweepPlan(clicks=CLICKS, frequencies_hz=(2.0,), warmup_cycles=1, measured_cycles=5)
    with start_sim_rig(SIM_RIG, speed=40, seed=seed, spec_path=spec) as sim:
        rig = sim.rig_config()
        with (
            RecordingWriter(out, metadata={"damper_id": out.stem}, rig_toml=rig.raw_toml) as w,
            LiveView(len(plan.points()), enabled=False) as view,
            RigSession(rig) as session,
        ):
            run_sweep(session, plan, w, view, sample_rate_hz=rig.sample_rate_hz)
    return out


@pytest.fixture(scope="module")
def sims(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("compare")
    text = default_spec_path().read_text(encoding="utf-8")
    assert text.count(AREA_LINE) == 1
    spec_b = d / "bigger-bleed.toml"
    spec_b.write_text(text.replace(AREA_LINE, "area_open_m2 = 1.8e-5 "), encoding="utf-8")
    fit = d / "fit.json"
    FitResult.from_spec(default_spec_path(), CLICKS).save(fit)
    return {
        "a": _sweep(d / "before.mcap", seed=1),
        "a2": _sweep(d / "again.mcap", seed=2),
        "b": _sweep(d / "after.mcap", seed=3, spec=spec_b),
        "spec_b": spec_b,
        "fit": fit,
    }


def _compare(tmp_path: Path, *args: str) -> dict[str, Any]:
    out, js = tmp_path / "page", tmp_path / "cmp.json"
    assert main(["compare", *args, "-o", str(out), "--json", str(js)]) == 0
    assert (out / "index.html").is_file()
    return dict(json.loads(js.read_text()))


class Compared(NamedTuple):
    doc: dict[str, Any]  # the --json file, read for this test alone
    err: str  # what the command said on standard error
    page: Path  # its -o folder: read it, or copy it to change it


@pytest.fixture(scope="module")
def compared(
    sims: dict[str, Path], tmp_path_factory: pytest.TempPathFactory
) -> Callable[[str, str], Compared]:
    """`compare FIRST SECOND -o PAGE --json FILE` of two of the sweeps, with no other
    option: made once, when a test first asks for it, and read by every test that checks
    that comparison (its rows, its terminal lines, its page); each made its own before."""
    made: dict[tuple[str, str], tuple[Path, str]] = {}

    def get(first: str, second: str) -> Compared:
        if (first, second) not in made:
            d = tmp_path_factory.mktemp(f"compare-{first}-{second}")
            done = cli("compare", str(sims[first]), str(sims[second]), "-o", str(d / "page"),
                       "--json", str(d / "cmp.json"))  # fmt: skip
            assert done.returncode == 0, done.stderr
            assert (d / "page" / "index.html").is_file()
            made[first, second] = d, done.stderr
        d, err = made[first, second]
        return Compared(dict(json.loads((d / "cmp.json").read_text())), err, d / "page")

    return get


def test_a_bigger_bleed_at_one_click_is_found_there_softer_and_nothing_else(
    sims: dict[str, Path], compared: Callable[[str, str], Compared]
) -> None:
    doc = compared("a", "b").doc
    rows = doc["rows"]
    assert len(rows) == 2 * 12  # both clicks, six speeds each way
    found = {(r["clicks"], r["direction"], r["velocity_m_s"]) for r in rows
             if r["verdict"] == "difference"}  # fmt: skip
    # Where the bleed carries the flow (before the shim stack opens) a 1.5x area must show.
    for v in (0.1, 0.15, 0.2):
        assert (CHANGED, "compression", v) in found
    # Nowhere else: not at the closed needle (0 clicks), not in rebound.
    assert {(c, d) for c, d, _ in found} == {(CHANGED, "compression")}
    for r in rows:
        if r["verdict"] == "difference":
            assert r["softer"] is True and r["diff_n"] < 0  # more bleed: less force
            assert abs(r["diff_n"]) > 3 * r["sd_diff_n"] and "softer" in r["text"]
    # Known truth: each spec's own model (mid-stroke, zero acceleration) gives the change
    # the sweep must show; measured 5, 19, 78, 175, 289, 106 N against 4.9, 19.4, 77.6,
    # 174.4, 288.5, 105.4 N in the run this was written with.
    speeds = clickchart.signed_velocities()
    truth_a = clickchart.model_forces(FitResult.from_spec(default_spec_path(), CLICKS),
                                      CHANGED, speeds, 0)  # fmt: skip
    truth_b = clickchart.model_forces(FitResult.from_spec(sims["spec_b"], CLICKS),
                                      CHANGED, speeds, 0)  # fmt: skip
    for r in rows:
        if r["clicks"] == CHANGED:
            v = r["velocity_m_s"]
            assert r["diff_n"] == pytest.approx(truth_b[v] - truth_a[v], rel=0.1, abs=3.0), v


def test_the_terminal_names_every_difference_largest_first(
    compared: Callable[[str, str], Compared],
) -> None:
    doc, err, _ = compared("a", "b")
    found = [r for r in doc["rows"] if r["verdict"] == "difference"]
    assert f"compare: {len(found)} of {len(doc['rows'])} values differ" in err
    lines = [line.strip() for line in err.splitlines() if line.startswith("  after vs before")]
    assert len(lines) == 1  # one setting and direction: 8 clicks, compression
    top = max(found, key=lambda r: abs(r["diff_n"]))
    assert lines[0].startswith(f"after vs before, clicks {CHANGED}: {top['text']}")
    for r in found:  # every speed that differs is on the line
        assert f"{r['velocity_m_s'] * 1e3:.3g}" in lines[0]


def test_more_than_ten_differences_are_all_said(tmp_path: Path) -> None:
    # 16 differences over 6 settings and directions (the sweep: the terminal
    # stopped at 10 and missed the six largest): every one is on a line, the largest first.
    rows = []
    for clicks, direction, forces in (
        (3, 1, [10, 20]), (8, 1, [30, 40, 50]), (8, -1, [60]),
        (15, 1, [70, 80]), (21, 1, [100, 150, 200, 255, 250, 240]), (21, -1, [90, 95]),
    ):  # fmt: skip
        for k, d in enumerate(forces):
            v = direction * (0.025, 0.05, 0.1, 0.15, 0.2, 0.3)[k]
            rows.append(Row("A", "B", clicks, 0, v, 1000.0 * direction,
                            1000.0 * direction - d, 2.0, DIFFERENCE))  # fmt: skip
    rows.append(Row("A", "B", 0, 0, 0.1, 500.0, 501.0, 2.0, WITHIN))
    lines = differences(rows)
    assert len(lines) == 6
    assert lines[0].startswith("B vs A, clicks 21: compression at 150 mm/s is 255 N")
    assert lines[0].endswith("(also at 25, 50, 100, 200, 300 mm/s)")
    tops = [int(re.search(r"is (\d+) N", line).group(1)) for line in lines]  # type: ignore[union-attr]
    assert tops == sorted(tops, reverse=True) == [255, 95, 80, 60, 50, 20]
    assert not any("clicks 0" in line for line in lines)


def test_the_same_damper_twice_is_within_the_scatter(sims: dict[str, Path], tmp_path: Path) -> None:
    doc = _compare(tmp_path, str(sims["a"]), str(sims["a2"]), "--label", "before=left")
    assert doc["reference"] == "left"
    rows = doc["rows"]
    assert rows and not [r for r in rows if r["verdict"] == "difference"]
    # Most are within the scatter itself, not only under the practical floor.
    assert sum(r["verdict"] == "within the scatter" for r in rows) >= 0.8 * len(rows)
    assert all(0 < r["sd_diff_n"] < 5 for r in rows)  # the sim's load cell: 2 N per sample


def test_json_and_page_contents(sims: dict[str, Path], tmp_path: Path) -> None:
    doc = _compare(tmp_path, str(sims["a"]), str(sims["b"]), "--units", "imperial")
    assert doc["schema"] == "shockdyno.compare/1"
    assert [i["kind"] for i in doc["inputs"]] == ["recording", "recording"]
    # The JSON stays SI whatever --units: the imperial standard velocities, in m/s.
    assert sorted({abs(r["velocity_m_s"]) for r in doc["rows"]}) == pytest.approx(
        [0.0254, 0.0508, 0.0762, 0.127, 0.254]
    )
    for r in doc["rows"]:
        assert r["diff_n"] == pytest.approx(r["force_b_n"] - r["force_a_n"], abs=1e-3)
    html = (tmp_path / "page" / "index.html").read_text(encoding="utf-8")
    for heading in ("Differences at the standard velocities", "Peak force vs peak velocity",
                    "Loops: same click and frequency", "Click charts side by side"):  # fmt: skip
        assert heading in html
    assert "lbf" in html and "in/s" in html
    for png in ("peaks.png", "loops_c00_g00_2Hz.png", "loops_c08_g00_2Hz.png", "chart_2.png"):
        assert (tmp_path / "page" / png).stat().st_size > 1000


def test_a_cut_off_recording_is_said_on_the_terminal_and_the_page(
    sims: dict[str, Path],
    compared: Callable[[str, str], Compared],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A recording cut off in its second test (a crash mid-write: the file ends there, no
    footer, the second test's chunk lost) compares on the test it holds, and says so, as
    fit and export do."""
    cut = tmp_path / "cut.mcap"
    data = sims["a2"].read_bytes()
    cut.write_bytes(data[: int(len(data) * 0.75)])
    rec = open_recording(cut)
    assert rec.truncated and [m.clicks for m in rec.tests] == [0]
    capsys.readouterr()
    doc = _compare(tmp_path, str(sims["a"]), str(cut))
    err = capsys.readouterr().err
    said = [line for line in err.splitlines() if line.startswith("compare: warning: cut:")]
    assert len(said) == 1 and "cut off" in said[0] and "1 tests read" in said[0], err
    assert "any test after the cut was never written" in said[0]
    assert [i["loss"] is None for i in doc["inputs"]] == [True, False]
    assert "cut off" in doc["inputs"][1]["loss"]
    assert {r["clicks"] for r in doc["rows"]} == {0}  # the lost test's click is not compared
    html = (tmp_path / "page" / "index.html").read_text(encoding="utf-8")
    assert "cut: the recording is cut off" in html and "compared on what was read" in html
    # a whole recording: nothing said
    assert "warning" not in compared("a", "a2").err


def test_a_recording_against_a_fit(sims: dict[str, Path], tmp_path: Path) -> None:
    doc = _compare(tmp_path, str(sims["a"]), "--fit", str(sims["fit"]))
    assert [i["kind"] for i in doc["inputs"]] == ["recording", "fit"]
    fit = FitResult.load(sims["fit"])
    for r in doc["rows"]:
        # damping force: the model's own force at rest removed, as from the recording's
        model = clickchart.model_forces(fit, r["clicks"], (r["velocity_m_s"],), 0)
        at_rest = clickchart.model_static_force_n(fit, r["clicks"], 0)
        assert r["force_b_n"] == pytest.approx(model[r["velocity_m_s"]] - at_rest, abs=1e-3)
    assert doc["bleed_areas"] and {e["clicks"] for e in doc["bleed_areas"]} == set(CLICKS)
    html = (tmp_path / "page" / "index.html").read_text(encoding="utf-8")
    assert "Fitted bleed areas" in html and "Fits have no loops" in html


def test_refuses_to_overwrite_without_force(
    sims: dict[str, Path],
    compared: Callable[[str, str], Compared],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    shutil.copytree(compared("a", "a2").page, tmp_path / "page")  # a page compare wrote
    before = (tmp_path / "page" / "index.html").stat().st_mtime_ns
    capsys.readouterr()
    args = ["compare", str(sims["a"]), str(sims["a2"]), "-o", str(tmp_path / "page")]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists (use --force" in err[0]
    assert (tmp_path / "page" / "index.html").stat().st_mtime_ns == before
    assert main([*args, "--json", str(tmp_path / "cmp.json"), "--force"]) == 0


def test_wrong_inputs_get_one_line(
    sims: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = tmp_path / "notes.txt"
    text.write_text("left damper, 12 clicks\n")
    diag = tmp_path / "diag.json"
    diag.write_text(json.dumps({"mismatch": {}, "findings": []}))
    other = tmp_path / "other.json"
    FitResult.from_spec(default_spec_path(), (3,)).save(other)
    cases = [
        ([str(sims["a"]), str(text)], "not JSON"),
        ([str(sims["a"]), str(diag)], "is a diagnosis"),
        ([str(sims["a"]), "--fit", str(sims["a2"])], "is an MCAP recording"),
        ([str(sims["a"]), str(tmp_path / "missing.mcap")], "not found"),
        ([str(sims["a"]), str(other)], "share no click setting"),
        ([str(sims["a"])], "two or more inputs"),
    ]
    for args, words in cases:
        capsys.readouterr()
        assert main(["compare", *args, "-o", str(tmp_path / "x")]) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], (args, err)
    assert not (tmp_path / "x" / "index.html").exists()


def test_json_to_standard_output_is_only_the_table(
    sims: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["compare", str(sims["a"]), str(sims["a2"]), "-o", str(tmp_path / "p"), "--json", "-"]
    assert main(args) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["reference"] == "before"
    assert "index.html" in captured.err


def test_two_fits_compare_their_bleed_areas(sims: dict[str, Path], tmp_path: Path) -> None:
    # The second spec opens the compression bleed 1.5x at every click above 0: +50 %.
    other = tmp_path / "bigger.json"
    FitResult.from_spec(sims["spec_b"], CLICKS).save(other)
    doc = _compare(tmp_path, str(sims["fit"]), str(other))
    assert {r["verdict"] for r in doc["rows"]} == {"not judged"}  # two models: no scatter
    by_click = {e["clicks"]: e["areas"] for e in doc["bleed_areas"]}
    ratio = by_click[CHANGED]["bigger"]["A_bc_m2"] / by_click[CHANGED]["fit"]["A_bc_m2"]
    assert ratio == pytest.approx(1.5)
    assert by_click[CHANGED]["bigger"]["A_bt_m2"] == by_click[CHANGED]["fit"]["A_bt_m2"]
    html = (tmp_path / "page" / "index.html").read_text(encoding="utf-8")
    assert "A_bc bigger vs fit (%)" in html and "+50.0" in html


def test_damping_force_by_default_and_raw_force_on_request(
    sims: dict[str, Path], compared: Callable[[str, str], Compared], tmp_path: Path
) -> None:
    """The table compares damping force (the sweep's measured gas force removed) and says
    so; --raw-force compares the force as measured: every value higher by that gas force."""
    damping, _, page = compared("a", "a2")
    raw = _compare(tmp_path, str(sims["a"]), str(sims["a2"]), "--raw-force")
    assert (damping["force"], raw["force"]) == ("damping", "raw")
    from shockdyno.record import open_recording

    gas = {t.meta.gas_force_n for t in open_recording(sims["a"]).load_all()}
    assert len(gas) >= 1 and all(g is not None and 200 < g < 260 for g in gas), gas
    pairs = zip(raw["rows"], damping["rows"], strict=True)
    shift = [r["force_a_n"] - d["force_a_n"] for r, d in pairs
             if r["force_a_n"] is not None and d["force_a_n"] is not None]  # fmt: skip
    assert len(shift) >= 20
    assert np.allclose(shift, np.median(sorted(g for g in gas if g is not None)), atol=0.5)
    html = (page / "index.html").read_text(encoding="utf-8")
    assert "gas force removed" in html and "measured at mid-stroke" in html


def test_side_by_side_click_charts_share_one_force_scale(sims: dict[str, Path]) -> None:
    """Each stroke's range covers every input's values (before and after on one scale)."""
    from shockdyno.compare.inputs import load_input
    from shockdyno.compare.page import _shared_limits

    speeds = clickchart.STANDARD_VELOCITIES_M_S
    inputs = [load_input(sims[k], k, speeds) for k in ("a", "b")]
    (c_lo, c_hi), (r_lo, r_hi) = _shared_limits(inputs)
    for inp in inputs:
        for row in inp.values.values():
            for v, val in row.items():
                lo, hi = (c_lo, c_hi) if v > 0 else (r_lo, r_hi)
                assert lo < val.force_n < hi, (inp.label, v, val.force_n)


def test_the_same_recording_twice_is_refused_and_two_fits_are_not_called_alike(
    sims: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["compare", str(sims["a"]), str(sims["a"]), "-o", str(tmp_path / "p")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "given twice" in err
    # Two fits have no scatter: the terminal says their values are not judged, rather
    # than that everything is "within the scatter".
    fit_b = tmp_path / "fit-b.json"
    FitResult.from_spec(sims["spec_b"], CLICKS).save(fit_b)
    assert main(["compare", str(sims["fit"]), str(fit_b), "-o", str(tmp_path / "q")]) == 0
    err = capsys.readouterr().err
    assert "no difference beyond the scatter; 24 of 24 values not judged" in err


def test_the_loops_that_differ_are_the_ones_opened(
    compared: Callable[[str, str], Compared],
) -> None:
    """Before/after with the change at 8 clicks: the page opens the 8-click loops, not the
    unchanged 0-click ones a reader would otherwise meet first."""
    html = (compared("a", "b").page / "index.html").read_text(encoding="utf-8")
    opened = re.findall(r"<details open><summary>(clicks \d+), gas", html)
    assert opened == ["clicks 8"], opened
    assert "<details><summary>clicks 0, gas 0, 2 Hz" in html
