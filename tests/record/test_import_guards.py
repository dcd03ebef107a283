"""`import` refuses what no dyno measures, data files outside the manifest's folder, devices
and oversized files, with one line, a non-zero exit and nothing written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from shockdyno.cli import main

ROWS = "".join(f"{i / 1000:.3f},{0.03 * (i % 7) / 7:.5f},{100.0 + i}\n" for i in range(50))
HEADER = "time_s,displacement_m,force_N\n"


def manifest(folder: Path, line: str = "a.csv,3,1,0.03") -> Path:
    m = folder / "manifest.csv"
    m.write_text("file,clicks,frequency_hz,amplitude_m\n" + line + "\n")
    return m


def run_import(capsys, m: Path, out: Path, *extra: str) -> tuple[int, str]:
    code = main(["import", str(m), "-o", str(out), *extra])
    err = capsys.readouterr().err
    return code, err


@pytest.mark.parametrize(
    ("data", "line", "words"),
    [
        (HEADER + "0,30.0,100\n0.001,30.0,101\n", None, "displacement 30 exceeds"),
        (HEADER + "0,0.01,1e308\n0.001,0.01,1\n", None, "force 1e+308 exceeds"),
        (HEADER + "0,0.01,1\n0.001,0.01,2\n", "a.csv,1e23,1,0.03", "not a whole number"),
        (HEADER + "0,0.01,1\n0.001,0.01,2\n", "a.csv,100000000000000000000000,1,0.03", "clicks"),
        (HEADER + "0,0.01,1\n0.001,0.01,2\n", "a.csv,3,1,30", "amplitude_m 30"),
    ],
)
def test_absurd_values_are_refused_and_nothing_is_written(capsys, tmp_path, data, line, words):
    (tmp_path / "a.csv").write_text(data)
    m = manifest(tmp_path, line or "a.csv,3,1,0.03")
    code, err = run_import(capsys, m, tmp_path / "r.mcap")
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "r.mcap").exists()


def test_1e307_kn_becomes_inf_and_is_refused(capsys, tmp_path):
    (tmp_path / "a.csv").write_text(HEADER + "0,0.01,1e307\n0.001,0.01,1\n")
    code, err = run_import(capsys, manifest(tmp_path), tmp_path / "r.mcap", "--force-unit", "kN")
    assert code == 2 and "not finite after unit conversion" in err


@pytest.mark.parametrize("name", ["../outside.csv", "/etc/passwd"])
def test_data_files_outside_the_manifest_folder_are_not_read(capsys, tmp_path, name):
    inner = tmp_path / "set"
    inner.mkdir()
    (tmp_path / "outside.csv").write_text(HEADER + ROWS)
    code, err = run_import(capsys, manifest(inner, f"{name},3,1,0.03"), tmp_path / "r.mcap")
    assert code == 2 and "outside the manifest's folder" in err
    if name.startswith(".."):  # allowed when asked for
        code, err = run_import(
            capsys, manifest(inner, f"{name},3,1,0.03"), tmp_path / "r.mcap",
            "--allow-outside-files",
        )  # fmt: skip
        assert code == 0, err


def test_a_device_is_not_read(capsys, tmp_path):
    code, err = run_import(capsys, manifest(tmp_path, "/dev/zero,3,1,0.03"), tmp_path / "r.mcap",
                           "--allow-outside-files")  # fmt: skip
    assert code == 2 and "not a regular file" in err


def test_a_file_over_the_size_bound_is_refused_before_reading(capsys, tmp_path):
    (tmp_path / "a.csv").write_text(HEADER + ROWS * 100)
    code, err = run_import(capsys, manifest(tmp_path), tmp_path / "r.mcap", "--max-file-mb", "0.01")
    assert code == 2 and "allowed for one file" in err


def test_mm_labelled_as_m_inside_the_bounds_is_warned_about(capsys, tmp_path):
    (tmp_path / "a.csv").write_text(HEADER + "0,0.3,1\n0.001,-0.3,2\n0.002,0.3,3\n")
    code, err = run_import(capsys, manifest(tmp_path, "a.csv,3,1,0.0003"), tmp_path / "r.mcap")
    assert code == 0 and "warning" in err and "mix-up" in err


def test_the_output_may_not_be_the_manifest(capsys, tmp_path):
    (tmp_path / "a.csv").write_text(HEADER + ROWS)
    m = manifest(tmp_path)
    before = m.read_text()
    code, err = run_import(capsys, m, m, "--force")
    assert code == 2 and "refusing to overwrite" in err
    assert m.read_text() == before


def test_reading_a_csv_peaks_within_3x_the_file(tmp_path):
    """Parsing is what used to cost ~20x; writing adds only the writer's fixed 1 MiB chunk."""
    import tracemalloc

    from shockdyno.record.csv_table import ImportOptions
    from shockdyno.record.manifest import read_manifest

    n = 30_000  # ~0.9 MB: tracemalloc slows every allocation
    t = np.arange(n) / 1000.0
    x = 0.03 * np.sin(2 * np.pi * t)
    f = 1500.0 * np.cos(2 * np.pi * t)
    lines = "".join(f"{a:.3f},{b:.6f},{c:.2f},40.00\n" for a, b, c in zip(t, x, f, strict=True))
    data = tmp_path / "a.csv"
    data.write_text("time_s,displacement_m,force_N,temperature_C\n" + lines)
    del lines
    size = data.stat().st_size
    m = manifest(tmp_path)
    tracemalloc.start()
    try:
        tests = read_manifest(m, ImportOptions())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(tests[0].block) == n
    assert peak <= 3 * size, f"peak {peak / 1e6:.2f} MB for a {size / 1e6:.2f} MB file"
