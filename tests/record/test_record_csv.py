"""CSV import and export: exchange-format round trips, other dynos' exports, malformed files."""

from __future__ import annotations

import csv
import tempfile
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from rec_helpers import SAMPLES_PER_TEST, block, seq_range, write_small

from shockdyno.cli import main
from shockdyno.record import open_recording
from shockdyno.record.csv_table import LBF_N


def write_exchange(d: Path) -> dict[str, str]:
    """Three tests in the exchange format, numbers written as shortest round-trip decimals."""
    d.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(1)
    files = {}
    rows = [
        ("c00_0.5hz.csv", 0, 0.5, True),
        ("c00_1hz.csv", 0, 1.0, False),
        ("c21.csv", 21, 1.5, True),
    ]
    for name, _clicks, freq, with_temp in rows:
        t = np.arange(600) / 1000.0
        x = np.round(0.03 * np.sin(2 * np.pi * freq * t), 6)
        f = np.round(900 * np.cos(2 * np.pi * freq * t) + rng.normal(0, 3, t.size), 2)
        head = "time_s,displacement_m,force_N" + (",temperature_C" if with_temp else "")
        lines = [head]
        for i, (ti, xi, fi) in enumerate(zip(t.tolist(), x.tolist(), f.tolist(), strict=True)):
            row = f"{ti!r},{xi!r},{fi!r}"
            lines.append(row + (f",{40 + i * 0.01:.2f}" if with_temp else ""))
        text = "\n".join(lines) + "\n"
        (d / name).write_text(text)
        files[name] = text
    manifest = "file,clicks,frequency_hz,amplitude_m,gas_clicks,note\n"
    manifest += "c00_0.5hz.csv,0,0.5,0.03,4,first\nc00_1hz.csv,0,1.0,0.03,4,\n"
    manifest += 'c21.csv,21,1.5,0.025,4,"a, b"\n'
    (d / "manifest.csv").write_text(manifest)
    return files


def read_manifest(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_exchange_import_then_export_reproduces_the_input(tmp_path: Path) -> None:
    files = write_exchange(tmp_path / "in")
    rec_path = tmp_path / "imp.mcap"
    assert main(["import", str(tmp_path / "in" / "manifest.csv"), "-o", str(rec_path)]) == 0
    rec = open_recording(rec_path)
    assert [(m.clicks, m.gas_clicks, m.frequency_hz, m.amplitude_m) for m in rec.tests] == [
        (0, 4, 0.5, 0.03),
        (0, 4, 1.0, 0.03),
        (21, 4, 1.5, 0.025),
    ]
    assert all(m.sample_rate_hz == 1000.0 and m.motion == "sine" for m in rec.tests)
    assert rec.tests[2].extra["note"] == "a, b"
    assert rec.load(1).temperature is None and rec.load(0).temperature is not None
    assert main(["export", str(rec_path), "--csv", str(tmp_path / "out")]) == 0
    for name, text in files.items():
        assert (tmp_path / "out" / name).read_text() == text  # byte for byte
    before, after = (
        read_manifest(tmp_path / "in" / "manifest.csv"),
        read_manifest(tmp_path / "out" / "manifest.csv"),
    )
    for a, b in zip(before, after, strict=True):
        assert b["file"] == a["file"] and b["clicks"] == a["clicks"] and b["note"] == a["note"]
        assert b["gas_clicks"] == a["gas_clicks"]
        assert float(b["frequency_hz"]) == float(a["frequency_hz"])
        assert float(b["amplitude_m"]) == float(a["amplitude_m"])


def test_recording_export_then_import_gives_the_same_arrays(tmp_path: Path) -> None:
    src = tmp_path / "sweep.mcap"
    write_small(src)
    assert main(["export", str(src), "--csv", str(tmp_path / "csv")]) == 0
    again = tmp_path / "again.mcap"
    assert main(["import", str(tmp_path / "csv" / "manifest.csv"), "-o", str(again)]) == 0
    rec = open_recording(again)
    for k, data in enumerate(rec.load_all()):
        truth = block(seq_range(k)[0], SAMPLES_PER_TEST)
        assert np.array_equal(data.t, truth.t_s)
        assert np.array_equal(data.x, truth.displacement_m)
        assert np.array_equal(data.force, truth.force_n)
        # 40 + seq·1e-4 °C lies on a 0.0001 grid: written as that decimal (40.0001, not
        # 40.000099999999996), it reads back within float64 rounding of the arithmetic.
        assert data.temperature is not None and truth.temperature_c is not None
        off = np.abs(data.temperature - truth.temperature_c)
        assert np.max(off) <= 8 * np.finfo(float).eps * 41 and np.max(off) > 0
        assert data.meta.warmup_cycles == 2 and data.meta.measured_cycles == 5
        assert data.meta.sample_rate_hz == 1000.0


def test_other_dyno_iso_timestamps_mm_lbf_300hz_slider_crank(tmp_path: Path) -> None:
    d = tmp_path / "roehrig"
    d.mkdir()
    n, rate = 900, 300
    start = datetime(2024, 5, 1, 9, 59, 59, 900000)
    micros = np.round(np.arange(n) * 1e6 / rate).astype(int)
    # slider-crank motion (crank 25 mm, rod 120 mm): not a sine
    theta = 2 * np.pi * 2.0 * micros / 1e6
    pos_mm = np.round(25 * np.cos(theta) + np.sqrt(120**2 - (25 * np.sin(theta)) ** 2) - 120, 3)
    load_lbf = np.round(150 * np.sin(theta), 2)
    lines = ["Timestamp;Pos_mm;Load_lbf;Temp_F"]
    for i in range(n):
        ts = (start + timedelta(microseconds=int(micros[i]))).isoformat() + "Z"
        lines.append(f"{ts};{pos_mm[i]};{load_lbf[i]};{104 + 0.0}")
    (d / "run7.csv").write_text("\n".join(lines) + "\n")
    (d / "m.csv").write_text("file;clicks;frequency_hz;amplitude_m\nrun7.csv;12;2;0.025\n")
    out = tmp_path / "r.mcap"
    argv = ["import", str(d / "m.csv"), "-o", str(out), "--delimiter", ";"]
    argv += ["--time-column", "Timestamp", "--displacement-column", "Pos_mm"]
    argv += ["--displacement-unit", "mm", "--force-column", "Load_lbf", "--force-unit", "lbf"]
    argv += ["--temperature-column", "Temp_F", "--temperature-unit", "F"]
    argv += ["--sample-rate-hz", "300", "--motion", "imported", "--meta", "operator=jo"]
    assert main(argv) == 0
    rec = open_recording(out)
    (m,) = rec.tests
    assert (m.clicks, m.frequency_hz, m.amplitude_m, m.motion) == (12, 2.0, 0.025, "imported")
    assert m.sample_rate_hz == 300.0
    assert rec.metadata["operator"] == "jo"
    data = rec.load(0)
    assert np.array_equal(data.t, micros / 1e6)  # relative to the first timestamp, across 10:00
    assert np.allclose(data.x, pos_mm * 1e-3, rtol=0, atol=1e-15)
    assert np.allclose(data.force, load_lbf * LBF_N, rtol=1e-15, atol=0)
    assert np.allclose(data.temperature, 40.0)
    assert np.array_equal(rec.samples(0).seq, np.arange(n))


def test_sample_rate_is_derived_from_the_time_column(tmp_path: Path) -> None:
    d = tmp_path / "in"
    write_exchange(d)
    rows = (d / "manifest.csv").read_text().splitlines()
    (d / "manifest.csv").write_text("\n".join(rows[:2]) + "\n")
    text = (d / "c00_0.5hz.csv").read_text().replace("0.001,", "0.0015,", 1)
    (d / "c00_0.5hz.csv").write_text(text)  # one odd step does not move the median
    assert main(["import", str(d / "manifest.csv"), "-o", str(tmp_path / "o.mcap")]) == 0
    assert open_recording(tmp_path / "o.mcap").tests[0].sample_rate_hz == 1000.0


def _edit(d: Path, name: str, line: int, new: str | None) -> None:
    """Replace (or with None, delete) 1-based line `line` of d/name."""
    lines = (d / name).read_text().splitlines()
    if new is None:
        del lines[line - 1]
    else:
        lines[line - 1] = new
    (d / name).write_text("\n".join(lines) + "\n")


BAD = [
    (
        "manifest.csv",
        1,
        "file,clicks,frequency_hz,amp,gas_clicks,note",
        "manifest.csv:1: no column 'amplitude_m'",
    ),
    (
        "manifest.csv",
        3,
        "c00_1hz.csv,three,1.0,0.03,4,",
        "manifest.csv:3: column 'clicks': 'three'",
    ),
    (
        "manifest.csv",
        4,
        "c21.csv,21,0,0.03,4,",
        "manifest.csv:4: column 'frequency_hz': '0' must be positive",
    ),
    ("manifest.csv", 2, "c09.csv,0,0.5,0.03,4,", "c09.csv: no such file"),
    ("manifest.csv", 2, "c00_0.5hz.csv,-1,0.5,0.03,4,", "manifest.csv:2: column 'clicks': -1"),
    ("c21.csv", 5, "0.003,0.001,abc,40", "c21.csv:5: column 'force_N': 'abc' is not a number"),
    ("c21.csv", 7, "0.005,nan,1.0,40", "c21.csv:7: column 'displacement_m': 'nan' is not a finite"),
    ("c21.csv", 4, "0.001,0.001,1.0,40", "c21.csv:4: column 'time_s': time does not increase"),
    ("c21.csv", 6, "0.004,0.001", "c21.csv:6: 2 fields, the header has 4"),
    ("c21.csv", 1, "t,displacement_m,force_N,temperature_C", "c21.csv:1: no column 'time_s'"),
    (
        "c00_1hz.csv",
        3,
        "2024-05-01 10:00,0.0,1.0",
        "c00_1hz.csv:3: column 'time_s': '2024-05-01 10:00'",
    ),
]


@pytest.mark.parametrize(("name", "line", "new", "message"), BAD)
def test_malformed_input_is_one_line_naming_file_line_and_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, line: int, new: str, message: str
) -> None:
    d = tmp_path / "in"
    write_exchange(d)
    _edit(d, name, line, new)
    out = tmp_path / "out" / "r.mcap"
    out.parent.mkdir()
    assert main(["import", str(d / "manifest.csv"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert message in err
    assert list(out.parent.iterdir()) == []  # no output, no temporary file left behind


def test_header_only_data_file_and_empty_manifest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    d = tmp_path / "in"
    write_exchange(d)
    (d / "c21.csv").write_text("time_s,displacement_m,force_N\n")
    assert main(["import", str(d / "manifest.csv"), "-o", str(tmp_path / "r.mcap")]) == 2
    assert "c21.csv:2: no data rows" in capsys.readouterr().err
    (d / "manifest.csv").write_text("file,clicks,frequency_hz,amplitude_m\n")
    assert main(["import", str(d / "manifest.csv"), "-o", str(tmp_path / "r.mcap")]) == 2
    assert "manifest.csv:2: the manifest lists no tests" in capsys.readouterr().err
    assert not (tmp_path / "r.mcap").exists()


def test_existing_outputs_need_force(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = tmp_path / "in"
    write_exchange(d)
    out = tmp_path / "r.mcap"
    out.write_bytes(b"precious")
    assert main(["import", str(d / "manifest.csv"), "-o", str(out)]) == 2
    assert "exists" in capsys.readouterr().err and out.read_bytes() == b"precious"
    assert main(["import", str(d / "manifest.csv"), "-o", str(out), "--force"]) == 0
    assert len(open_recording(out).tests) == 3
    target = tmp_path / "csv"
    target.mkdir()
    (target / "keep.txt").write_text("x")
    assert main(["export", str(out), "--csv", str(target)]) == 2
    assert "not empty" in capsys.readouterr().err
    assert sorted(p.name for p in target.iterdir()) == ["keep.txt"]
    assert main(["export", str(out), "--csv", str(target), "--force"]) == 0
    assert (target / "manifest.csv").exists() and (target / "keep.txt").read_text() == "x"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_other_units_and_fixed_decimals_survive_a_round_trip(tmp_path: Path) -> None:
    d = tmp_path / "in"
    d.mkdir()
    (d / "a.csv").write_text("ms,inch,kN\n0.0,1.000,0.50\n2.5,0.500,-0.25\n5.0,0.000,1.25\n")
    (d / "m.csv").write_text("file,clicks,frequency_hz,amplitude_m\na.csv,4,2,0.0254\n")
    out = tmp_path / "r.mcap"
    argv = ["import", str(d / "m.csv"), "-o", str(out), "--time-column", "ms"]
    argv += ["--time-unit", "ms", "--displacement-column", "inch", "--displacement-unit", "in"]
    argv += ["--force-column", "kN", "--force-unit", "kN"]
    assert main(argv) == 0
    data = open_recording(out).load(0)
    assert np.allclose(data.t, [0.0, 0.0025, 0.005], rtol=0, atol=1e-15)
    assert np.allclose(data.x, [0.0254, 0.0127, 0.0], rtol=0, atol=1e-15)
    assert np.allclose(data.force, [500.0, -250.0, 1250.0], rtol=0, atol=1e-12)
    assert data.meta.sample_rate_hz == 400.0
    assert main(["export", str(out), "--csv", str(tmp_path / "out")]) == 0
    # ms -> s keeps 1 + 3 decimals; kN -> N keeps 2 - 3 -> 0; inches have no decimal rule
    assert (tmp_path / "out" / "a.csv").read_text().splitlines() == [
        "time_s,displacement_m,force_N",
        "0.0000,0.0254,500",
        "0.0025,0.0127,-250",
        "0.0050,0.0,1250",
    ]


def test_iso_times_mixing_time_zones_are_rejected(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    d = tmp_path / "in"
    d.mkdir()
    rows = ["Timestamp,displacement_m,force_N", "2024-05-01T10:00:00,0,1"]
    rows += ["2024-05-01T10:00:00.001+00:00,0,1"]
    (d / "a.csv").write_text("\n".join(rows) + "\n")
    (d / "m.csv").write_text("file,clicks,frequency_hz,amplitude_m\na.csv,4,2,0.03\n")
    argv = [
        "import",
        str(d / "m.csv"),
        "-o",
        str(tmp_path / "r.mcap"),
        "--time-column",
        "Timestamp",
    ]
    assert main(argv) == 2
    assert "a.csv:3: column 'Timestamp': mixes date-times" in capsys.readouterr().err


# Any float a dyno can measure (beyond ±1 m or ±1 MN an import is refused: test_import_guards)
metres = st.floats(-1.0, 1.0, width=64)
newtons = st.floats(-1e6, 1e6, width=64)


@settings(max_examples=30, deadline=None)
@given(
    steps=st.lists(st.floats(1e-6, 10.0), min_size=1, max_size=40),
    values=st.data(),
)
def test_any_float_values_come_back_text_identical(
    steps: list[float], values: st.DataObject
) -> None:
    t = np.cumsum([0.0, *steps]).tolist()
    x = values.draw(st.lists(metres, min_size=len(t), max_size=len(t)))
    f = values.draw(st.lists(newtons, min_size=len(t), max_size=len(t)))
    assume(bool(np.all(np.diff(t) > 0)))  # tiny steps on a large time can round away
    text = "time_s,displacement_m,force_N\n"
    text += "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(t, x, f, strict=True))
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / "a.csv").write_text(text)
        (d / "m.csv").write_text("file,clicks,frequency_hz,amplitude_m,sample_rate_hz\n")
        with open(d / "m.csv", "a") as m:
            m.write("a.csv,1,1,0.03,1000\n")
        assert main(["import", str(d / "m.csv"), "-o", str(d / "r.mcap")]) == 0
        assert main(["export", str(d / "r.mcap"), "--csv", str(d / "out")]) == 0
        assert (d / "out" / "a.csv").read_text() == text


def test_a_rig_recording_exports_at_its_channels_resolution_with_the_analysis_velocity(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Counts times a calibration (0.05 N, 1 µm, 0.01 °C a count) read 229.10000000000002
    in the CSV (issue 20): each channel is written at its resolution, the text survives
    import and export byte for byte, and velocity_m_s is the derivative the fit takes."""
    import re
    from dataclasses import replace

    from report_helpers import make_test, write_recording
    from shockdyno.fit.prepare import prepare_tests
    from shockdyno.model.kinematics import DEFAULT_WINDOW_S

    test = make_test(0, 7, 1.5, cycles=2)
    assert test.temperature is not None
    # What rig/daq.py does: counts * gain + offset, the LVDT's offset the stroke centre.
    test = replace(
        test,
        x=np.rint((test.x + 0.075) / 1e-6) * 1e-6 - 0.075,
        force=np.rint(test.force / 0.05) * 0.05,
        temperature=np.rint(test.temperature / 0.01) * 0.01,
    )
    rec = write_recording(tmp_path / "rig.mcap", [test], {"damper_id": "rig"})
    stored = open_recording(rec).load(0)
    # What the old export wrote: the float64 arithmetic's noise in many cells.
    assert sum(len(repr(v)) > 12 for v in stored.force.tolist()) > 100
    out = tmp_path / "csv"
    assert main(["export", str(rec), "--csv", str(out)]) == 0
    (name,) = [p.name for p in out.glob("test*.csv")]
    lines = (out / name).read_text().splitlines()
    assert lines[0] == "time_s,displacement_m,force_N,temperature_C,velocity_m_s"
    rows = [line.split(",") for line in lines[1:]]
    cols = list(zip(*rows, strict=True))
    for cells, places in zip(cols, (3, 6, 2, 2, 6), strict=True):
        assert {len(c) - c.index(".") - 1 for c in cells} == {places}
        assert not [c for c in cells if re.search(r"(0{6,}|9{6,})\d$", c)]
    for cells, values in zip(cols[:3], (stored.t, stored.x, stored.force), strict=True):
        back = np.array([float(c) for c in cells])
        assert np.max(np.abs(back - values)) <= 8 * np.finfo(float).eps * np.max(np.abs(values))
    # The velocity is the analysis's own derivative of these samples, inside the measured
    # window (away from its ends, where the filter sees fewer samples).
    (prepared,), _ = prepare_tests([stored])
    t_csv = np.array([float(c) for c in cols[0]])
    at = np.searchsorted(t_csv, prepared.data.t - 1e-9)
    assert np.allclose(t_csv[at], prepared.data.t, rtol=0, atol=1e-12)
    edge = round(DEFAULT_WINDOW_S * 1000)
    v_csv = np.array([float(c) for c in cols[4]])[at][edge:-edge]
    assert np.max(np.abs(v_csv - prepared.v[edge:-edge])) <= 6e-7  # 6 places, rounded
    assert np.ptp(v_csv) > 0.5  # ±0.28 m/s: a stroke, not a constant
    # Export, import, export: the same text, velocity included.
    again = tmp_path / "again.mcap"
    assert main(["import", str(out / "manifest.csv"), "-o", str(again)]) == 0
    assert main(["export", str(again), "--csv", str(tmp_path / "csv2")]) == 0
    assert (tmp_path / "csv2" / name).read_text() == (out / name).read_text()
    capsys.readouterr()
    # The exchange format is SI, as its column names say: imperial is for damper tables.
    assert main(["export", str(rec), "--csv", str(tmp_path / "x"), "--units", "imperial"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--csv writes SI units" in err


def test_a_measured_gas_force_survives_export_and_import(tmp_path: Path) -> None:
    """The manifest carries each test's gas force and its source: a review found a
    re-imported sweep estimated 236 N where the sweep had measured 231 N. A test without
    one stays without; the manifest of a recording with none has no such columns."""
    src = tmp_path / "sweep.mcap"
    write_small(src, gas_force_n=(230.7, None, 231.25))
    assert main(["export", str(src), "--csv", str(tmp_path / "csv")]) == 0
    header = (tmp_path / "csv" / "manifest.csv").read_text().splitlines()[0].split(",")
    assert "gas_force_n" in header and "gas_force_source" in header
    again = tmp_path / "again.mcap"
    assert main(["import", str(tmp_path / "csv" / "manifest.csv"), "-o", str(again)]) == 0
    got = [(t.meta.gas_force_n, t.meta.gas_force_source) for t in open_recording(again).load_all()]
    assert got == [(230.7, "measured"), (None, None), (231.25, "measured")]
    plain = tmp_path / "plain.mcap"
    write_small(plain)
    assert main(["export", str(plain), "--csv", str(tmp_path / "csv2")]) == 0
    assert "gas_force" not in (tmp_path / "csv2" / "manifest.csv").read_text()
