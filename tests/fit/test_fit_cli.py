"""`shockdyno fit` on a real MCAP recording written by the project's writer."""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from fit_helpers import true_spec

from shockdyno.cli import main
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.record import RecordingWriter
from shockdyno.samples import SampleBlock

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two clicks x three frequencies, on one continuous DAQ time base, temperature included."""
    path = tmp_path_factory.mktemp("rec") / "sweep.mcap"
    tests = synthetic_sweep(true_spec(), [3, 11], cycles=1, seed=21, temperature_c=40.0)
    seq0 = 0
    with RecordingWriter(path, metadata={"source": "fit test"}) as writer:
        for test in tests:
            n = test.t.size
            seq = np.arange(seq0, seq0 + n, dtype=np.int64)
            t = seq / test.meta.sample_rate_hz
            meta = replace(test.meta, measured_start_s=float(t[0]), measured_end_s=float(t[-1]))
            assert test.temperature is not None
            block = SampleBlock(
                seq, t, test.x, test.force, test.temperature, np.zeros(n, np.uint16)
            )
            writer.begin_test(meta)
            writer.write_samples(block)
            writer.end_test(meta)
            seq0 += n + 500  # a pause between tests
    return path


def test_fit_command_writes_json_report_and_table(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "fit.json"
    report = tmp_path / "report"
    code = main(["fit", str(recording), "--json", str(out), "--report", str(report)])
    printed = capsys.readouterr().out
    assert code == 0
    doc = json.loads(out.read_text())
    assert [c["clicks"] for c in doc["clicks"]] == [3, 11]
    assert len(doc["tests"]) == 6
    for t in doc["tests"]:
        assert t["proposed"]["E_t"] <= 0.05
        assert t["proposed"]["E_t"] < t["talbott"]["E_t"]
        assert t["temperature_mean_C"] == pytest.approx(40.0, abs=0.1)
    truth = true_spec()
    for c in doc["clicks"]:
        assert c["A_bc_m2"] == pytest.approx(float(truth.bleed_areas(c["clicks"])[0]), rel=0.1)
        assert c["A_bt_m2"] == pytest.approx(float(truth.bleed_areas(c["clicks"])[1]), rel=0.1)
    assert set(doc["globals"]) >= {"gas_pressure_pa", "friction_n"}
    assert "Enhancement (%)" in printed and "Talbott" in printed
    # Which spec: on the terminal, in the JSON (spec_path) and on the page, never absolute there.
    assert "spec: built-in default sim/ohlins-s46.toml (ohlins-s46)" in printed
    assert Path(doc["spec_path"]).name == "ohlins-s46.toml"
    # Every fitted global is printed in engineering units (the JSON stays SI), and the
    # force channel's delay in ms
    assert "Calibrated globals" in printed
    lines = printed.splitlines()
    engineering = {"gas_pressure_pa": (1e-5, "bar"), "friction_n": (1.0, "N")}
    engineering |= {f"{v}_valve.preload_m": (1e3, "mm") for v in ("compression", "rebound")}
    engineering |= {f"{v}_valve.face_area_m2": (1e6, "mm²") for v in ("compression", "rebound")}
    for key, value in doc["globals"].items():
        row = next(ln for ln in lines if f" {key} " in ln)
        factor, label = engineering[key]
        assert f"{value * factor:.4g}" in row and f" {label} " in row, (key, row)
    delay_ms = doc["info"]["calibration"]["force_delay_s"] * 1e3
    # within 0.1 % of its 0-50 ms range (fit/display.BOUND_SHARE) the row names the bound
    shown = f"{delay_ms:.4g}" if delay_ms > 0.05 else "at lower bound (0 ms)"
    assert shown in next(ln for ln in lines if "force delay" in ln)
    pngs = sorted(report.glob("*.png"))
    assert len(pngs) >= 3  # areas vs clicks, and overlays
    for p in pngs:
        assert p.read_bytes()[:8] == PNG_MAGIC and p.stat().st_size > 10_000
    # One page with the fit on it, linking the figures beside it:
    page = (report / "index.html").read_text(encoding="utf-8")
    assert "Fit and validation" in page and "Click chart" in page
    # The page's globals in engineering units too: the gas charge in bar, areas in mm²
    assert "Calibrated globals" in page and "<td>mm²</td>" in page
    assert f'<td class="num">{doc["globals"]["gas_pressure_pa"] * 1e-5:.4g}</td>' in page
    assert "base spec sim/ohlins-s46.toml" in page and doc["spec_path"] not in page
    for p in pngs:
        assert f'src="{p.name}"' in page
    rows = list(csv.reader((report / "table4.csv").read_text().splitlines()))
    assert rows[0][:2] == ["Frequency (Hz)", "Model"]
    assert [r[1] for r in rows[1:]] == ["Proposed", "Talbott", "Enhancement (%)"] * 3
    # The table's E_t is the mean over that frequency's tests in the JSON.
    for i, f in enumerate(sorted({t["frequency_hz"] for t in doc["tests"]})):
        mean = np.mean([t["proposed"]["E_t"] for t in doc["tests"] if t["frequency_hz"] == f])
        assert float(rows[1 + 3 * i][2]) == pytest.approx(mean, rel=1e-3)


def test_ga_option_is_seeded(recording: Path, tmp_path: Path) -> None:
    docs = []
    for name in ("a", "b"):
        out = tmp_path / f"{name}.json"
        assert (
            main(["fit", str(recording), "--json", str(out), "--optimizer", "ga", "--seed", "3"])
            == 0
        )
        docs.append(json.loads(out.read_text()))
    assert docs[0]["clicks"] == docs[1]["clicks"]
    assert docs[0]["info"]["optimizer"] == "ga"


@pytest.mark.parametrize(
    "args",
    [
        ["fit", "/nonexistent/rec.mcap", "--json", "{tmp}/x.json"],
        ["fit", "{rec}", "--json", "/nonexistent-dir/x.json"],
        ["fit", "{rec}", "--json", "{tmp}/x.json", "--spec", "{tmp}/missing.toml"],
        ["fit", "{garbage}", "--json", "{tmp}/x.json"],
    ],
)
def test_user_mistakes_are_one_line_errors(
    args: list[str], recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"not an mcap file at all" * 10)
    argv = [a.format(tmp=tmp_path, rec=recording, garbage=garbage) for a in args]
    code = main(argv)
    err = capsys.readouterr().err
    assert code != 0
    assert err.startswith("shockdyno fit: error:") and err.count("\n") == 1
    assert not (tmp_path / "x.json").exists()


def test_a_value_pressed_against_a_bound_reads_which_bound() -> None:
    """An optimiser at a bound of 0 leaves 1.7e-28 there: the tables print "at lower bound
    (0 ms)" in place of it (issue 20), a value at another bound names that one, and a real
    small value or an unflagged one is printed as it is, in display units."""
    from rich.console import Console

    from shockdyno.commands.fit import _area, terms_table
    from shockdyno.fit.display import shown
    from shockdyno.model.params import Estimate
    from shockdyno.units import SI

    terms = {
        "sensor_lag": {
            "delay_s": Estimate(0.0021, 1e-4, "s"),
            "load_cell_lag_s": Estimate(1.7e-28, 2e-5, "s", at_bound=True),
        },
        "compressibility": {"air_fraction": Estimate(0.3, 0.01, "1", at_bound=True)},
        "thermal": {"cooling_time_s": Estimate(300.0, 12.0, "s")},
    }
    console = Console(width=200, record=True)
    console.print(terms_table(terms))
    text = console.export_text()
    assert "1.7e-28" not in text
    lag = next(line for line in text.splitlines() if "load_cell_lag_s" in line)
    assert "at lower bound (0 ms)" in lag and " ms " in lag
    delay = next(line for line in text.splitlines() if "delay_s" in line)
    assert " 2.1 " in delay and " 0.1 " in delay  # 0.0021 s ± 1e-4 s in ms
    # a time constant of minutes in s (it read 3e+05 ms), a delay in ms
    cooling = next(line for line in text.splitlines() if "cooling_time_s" in line)
    assert " 300 " in cooling and " s " in cooling and " ms " not in cooling
    air = next(line for line in text.splitlines() if "air_fraction" in line)
    assert "at upper bound (0.3)" in air  # compressibility's air fraction tops out at 0.3
    mm2 = shown("m²", SI)
    assert _area(1e-24, float("nan"), mm2) == "0" and _area(2.5e-6, 2.5e-7, mm2) == "2.5 ±10%"


def test_imperial_tables_are_the_si_numbers_converted(
    recording: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """--units imperial: the same fit, its N in lbf, m/s in in/s, bar in psi, mm² in in²
    (each cell the SI one times the factor, not only a new label); the JSON stays SI."""
    import re

    from shockdyno.units import M_PER_IN, N_PER_LBF

    # pytest-xdist's workers set COLUMNS=80, which a table honours as a terminal's width
    monkeypatch.delenv("COLUMNS", raising=False)
    cells: dict[str, dict[str, list[str]]] = {}
    docs = {}
    for units in ("si", "imperial"):
        out = tmp_path / f"{units}.json"
        argv = ["fit", str(recording), "--json", str(out), "--terms", "friction"]
        assert main([*argv, "--units", units]) == 0
        doc = json.loads(out.read_text())
        docs[units] = (doc["globals"], doc["terms"], doc["clicks"])
        lines = capsys.readouterr().out.splitlines()
        rows = [[c.strip() for c in ln.split("│")[1:-1]] for ln in lines if ln.startswith("│")]
        cells[units] = {r[1] if r[0] == "friction" else r[0]: r for r in rows if len(r) > 2}
    assert docs["si"] == docs["imperial"]  # the JSON is SI whatever the tables show
    si, imp = cells["si"], cells["imperial"]

    def close(a: str, b: str, factor: float) -> None:
        assert float(b) == pytest.approx(float(a) * factor, rel=2e-3), (a, b)

    assert si["friction_n"][4] == "N" and imp["friction_n"][4] == "lbf"
    close(si["friction_n"][1], imp["friction_n"][1], 1 / N_PER_LBF)
    close(si["friction_n"][3], imp["friction_n"][3], 1 / N_PER_LBF)
    assert imp["gas_pressure_pa"][4] == "psi"
    close(si["gas_pressure_pa"][1], imp["gas_pressure_pa"][1], 1e5 / N_PER_LBF * M_PER_IN**2)
    assert imp["compression_valve.face_area_m2"][4] == "in²"
    close(
        si["compression_valve.face_area_m2"][3],
        imp["compression_valve.face_area_m2"][3],
        1e-6 / M_PER_IN**2,
    )
    # The friction term: a velocity in in/s, a force in lbf (a number or a named bound).
    for name, label_si, label_imp, factor in (
        ("stribeck_velocity_m_s", "mm/s", "in/s", 1e-3 / M_PER_IN),
        ("breakaway_n", "N", "lbf", 1 / N_PER_LBF),
    ):
        a, b = si[name], imp[name]
        assert (a[4], b[4]) == (label_si, label_imp)
        num = re.compile(r"[-+]?[0-9.]+(?:e[-+]?\d+)?")
        close(num.findall(a[2])[-1], num.findall(b[2])[-1], factor)


def test_piped_tables_are_written_whole(tmp_path: Path) -> None:
    """A fit's tables sent to a pipe or a log file were cut at rich's 80 columns (cells
    ending in '…'): off a terminal they are written at 200 (issue 20)."""
    import os
    import re
    import subprocess
    import sys

    example = Path(__file__).resolve().parents[2] / "recordings" / "examples" / "example.mcap"
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
    cmd = [sys.executable, "-m", "shockdyno.cli", "fit", str(example)]
    cmd += ["--json", str(tmp_path / "fit.json")]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0, done.stderr[-300:]
    # A row whose first cell is blank is a wrapped row: at 80 columns the bleed table
    # put "±1.3e+03%" on a line of its own under "0.0009361".
    text = done.stdout
    bleeds = text[text.index("Bleed areas per click") :]
    bleeds = bleeds[: bleeds.index("└")]
    wrapped = [line for line in bleeds.splitlines() if re.match(r"^│\s+│", line)]
    assert not wrapped, "\n".join(wrapped)
    assert "…" not in done.stdout


def test_the_globals_tables_force_delay_at_zero_reads_at_lower_bound() -> None:
    """The force channel's delay row (the globals table, terminal and page): 8.4e-19 s is
    the bound 0, as the terms table says it; a real delay is printed in ms."""
    from shockdyno.fit.display import globals_rows
    from shockdyno.fit.result import FitResult
    from shockdyno.fit.result_doc import CalibrationInfo
    from shockdyno.model import default_spec_path

    result = FitResult.from_spec(default_spec_path(), (0, 10))
    for delay, want in ((8.4e-19, "at lower bound (0 ms)"), (0.0021, "2.1")):
        cal = CalibrationInfo(force_delay_s=delay, force_delay_sd_s=1e-5)
        result.info = replace(result.info, calibration=cal)
        (row,) = [r for r in globals_rows(result)[1] if r[0] == "force delay"]
        assert row[1] == want, row


def test_no_test_to_fit_says_how_many_were_read() -> None:
    """A recording cut off before its first test ended holds no test: the error says so
    instead of ending on a colon."""
    from shockdyno.errors import FitError
    from shockdyno.fit import fit_sweep

    with pytest.raises(FitError, match=r"samples\): 0 tests read \(a recording cut off"):
        fit_sweep([], None)
