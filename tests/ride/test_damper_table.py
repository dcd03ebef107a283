"""`shockdyno export FIT.json --damper-table DIR`: files parsed back against the model."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest

from shockdyno.cli import main
from shockdyno.fit.result import FitResult
from shockdyno.model.params import Estimate
from shockdyno.model.quarter_car import TabulatedDamper, quasi_static_force
from shockdyno.ride.damper_table import M_PER_IN, N_PER_LBF, read_teimorbit

REPO = Path(__file__).resolve().parents[2]
SPEC = REPO / "sim" / "ohlins-s46.toml"


@pytest.fixture
def fit_json(tmp_path: Path) -> Path:
    """The spec's own areas at three clicks, with seal friction as a fitted term (so the
    vehicle model is not the bare paper model) and a delay the car must drop."""
    fit = FitResult.from_spec(SPEC, [0, 10, 21])
    fit.terms = {
        "friction": {
            "breakaway_n": Estimate(20.0, 1.0, "N"),
            "stribeck_velocity_m_s": Estimate(0.006, 0.001, "m/s"),
            "viscous_n_s_m": Estimate(60.0, 5.0, "N·s/m"),
        },
        "sensor_lag": {"delay_s": Estimate(0.004, 0.0002, "s")},
    }
    path = tmp_path / "fit.json"
    fit.save(path)
    return path


def _model_force(fit_path: Path, clicks: int, v_m_s: np.ndarray) -> np.ndarray:
    fit = FitResult.load(fit_path)
    a_bc, a_bt = fit.areas(clicks)
    z = np.zeros_like(v_m_s)
    return np.asarray(quasi_static_force(fit.model().vehicle(), z, v_m_s, z, a_bc, a_bt))


def _csv_rows(path: Path) -> tuple[list[str], np.ndarray]:
    lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")]
    rows = list(csv.reader(io.StringIO("\n".join(lines))))
    return rows[0], np.array(rows[1:], dtype=float)


def test_property_file_and_csv_read_back_match_the_model(fit_json: Path, tmp_path: Path) -> None:
    out = tmp_path / "tables"
    assert main(["export", str(fit_json), "--damper-table", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        f"clicks_{c:02d}.{s}" for c in (0, 10, 21) for s in ("csv", "dpr")
    ]
    for clicks in (0, 10, 21):
        curve = read_teimorbit((out / f"clicks_{clicks:02d}.dpr").read_text())
        assert curve.units["LENGTH"] == "mm" and curve.units["FORCE"] == "newton"
        assert np.all(np.diff(curve.velocity) > 0)
        # The file's convention is extension positive: ours is compression positive.
        v = -curve.velocity * 1e-3
        total = _model_force(fit_json, clicks, v)
        gas = float(_model_force(fit_json, clicks, np.zeros(1))[0])
        damping = -(total - gas)
        assert np.allclose(curve.force, damping, rtol=1e-3, atol=1e-3)
        # A damper opposes motion: damping force has the sign of (extension) velocity.
        moving = curve.velocity != 0
        assert np.all(np.sign(curve.force[moving]) == np.sign(curve.velocity[moving]))
        assert gas > 100  # the nitrogen charge pushes the rod out

        header, rows = _csv_rows(out / f"clicks_{clicks:02d}.csv")
        assert header == ["velocity_mm_s", "force_N", "damping_force_N"]
        v_csv = rows[:, 0] * 1e-3
        assert np.allclose(rows[:, 1], _model_force(fit_json, clicks, v_csv), rtol=1e-3)
        assert np.allclose(rows[:, 1] - rows[:, 2], gas, rtol=1e-3)
        assert "e-" not in (out / f"clicks_{clicks:02d}.csv").read_text().split("\n", 3)[3]


def test_the_table_is_the_damper_the_ride_study_drives(fit_json: Path, tmp_path: Path) -> None:
    out = tmp_path / "tables"
    assert main(["export", str(fit_json), "--damper-table", str(out), "--clicks", "10"]) == 0
    _, rows = _csv_rows(out / "clicks_10.csv")
    fit = FitResult.load(fit_json)
    ride = TabulatedDamper(fit.model(), [fit.areas(10)], [0])
    at_mid = ride.force_at_rest_n + np.interp(rows[:, 0] * 1e-3, ride.v_grid, ride.h_table[0])
    assert np.allclose(rows[:, 1], at_mid, rtol=2e-3, atol=2.0)


def test_imperial_units_are_the_same_curve(fit_json: Path, tmp_path: Path) -> None:
    """The imperial table's grid is round in/s (1, 2, 3, 5, 10 ... not 0.984252), and at
    those speeds the forces are the SI table's at the same speeds, converted."""
    si, imp = tmp_path / "si", tmp_path / "imp"
    assert main(["export", str(fit_json), "--damper-table", str(imp), "--units", "imperial"]) == 0
    b = read_teimorbit((imp / "clicks_21.dpr").read_text())
    speeds_in_s = sorted({abs(float(v)) for v in b.velocity if v != 0})
    assert {1.0, 2.0, 3.0, 5.0, 10.0} <= set(speeds_in_s)
    assert all(float(f"{v:.2f}") == v for v in speeds_in_s)  # no 0.984252
    mm_s = ",".join(f"{v * M_PER_IN * 1e3:.10g}" for v in speeds_in_s)
    assert (
        main(["export", str(fit_json), "--damper-table", str(si), "--velocities-mm-s", mm_s]) == 0
    )
    a = read_teimorbit((si / "clicks_21.dpr").read_text())
    assert b.units["LENGTH"] == "inch" and b.units["FORCE"] == "pound_force"
    assert np.allclose(b.velocity * M_PER_IN * 1e3, a.velocity, rtol=1e-5)
    assert np.allclose(b.force * N_PER_LBF, a.force, rtol=1e-5, atol=1e-4)
    header, _ = _csv_rows(imp / "clicks_21.csv")
    assert header == ["velocity_in_s", "force_lbf", "damping_force_lbf"]


def test_trend_clicks_and_refusals(
    fit_json: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tables"
    assert main(["export", str(fit_json), "--damper-table", str(out), "--clicks", "0"]) == 0
    before = (out / "clicks_00.dpr").read_bytes()
    capsys.readouterr()
    # No overwrite without --force; nothing written by a refused call.
    assert main(["export", str(fit_json), "--damper-table", str(out), "--clicks", "0"]) == 2
    assert "exists" in capsys.readouterr().err
    assert (out / "clicks_00.dpr").read_bytes() == before
    # A click the fit has neither fitted nor a trend for.
    assert main(["export", str(fit_json), "--damper-table", str(tmp_path / "x"), "--clicks", "5"])
    err = capsys.readouterr().err
    assert "5 clicks" in err and err.count("\n") == 1
    # A recording given where a fit is expected: one line, nothing written.
    rec = REPO / "recordings" / "examples" / "example.mcap"
    assert main(["export", str(rec), "--damper-table", str(tmp_path / "y")]) == 2
    err = capsys.readouterr().err
    assert "MCAP recording" in err and err.count("\n") == 1
    assert not (tmp_path / "y").exists()
    # --clicks belongs to the damper table, not to the CSV exchange.
    assert main(["export", str(rec), "--csv", str(tmp_path / "z"), "--clicks", "0"]) == 2
    assert "goes with --damper-table" in capsys.readouterr().err


@pytest.fixture(scope="module")
def fitted_example(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`shockdyno fit` of the shipped example: 1 Hz sines of 30 mm at clicks 0 and 21, so
    the recording reached 2π · 1 Hz · 30 mm = 188.5 mm/s each way."""
    out = tmp_path_factory.mktemp("fit") / "fit.json"
    rec = REPO / "recordings" / "examples" / "example.mcap"
    assert main(["fit", str(rec), "--json", str(out), "--terms", "none"]) == 0
    return out


PEAK_M_S = 2 * np.pi * 1.0 * 0.03


def test_rows_beyond_the_measured_velocities_are_marked(
    fitted_example: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Issue 47.5: the default grid runs to 1000 mm/s; the recording reached 188.5.
    spans = FitResult.load(fitted_example).info.velocity_range or ()
    assert [(e.clicks, e.gas_clicks) for e in spans] == [(0, 0), (21, 0)]
    for e in spans:  # the sine's own peak velocity, from its samples
        assert e.compression_m_s == pytest.approx(PEAK_M_S, rel=2e-3)
        assert -e.rebound_m_s == pytest.approx(PEAK_M_S, rel=2e-3)
    out = tmp_path / "tables"
    assert main(["export", str(fitted_example), "--damper-table", str(out)]) == 0
    said = capsys.readouterr().out
    assert (
        "clicks 21: measured to 188.5 / 188.6 mm/s (rebound / compression); 16 rows beyond" in said
    )
    header, rows = _csv_rows(out / "clicks_21.csv")
    assert header[-1] == "measured"
    inside = np.abs(rows[:, 0]) <= PEAK_M_S * 1e3
    assert np.array_equal(rows[:, 3] == 1, inside) and rows[:, 0].max() == 1000
    assert "beyond, the model extrapolated" in (out / "clicks_21.dpr").read_text()
    # Click 0's bleed is not identifiable (a closed needle), so the trend rests on click 21
    # alone: a table at 10 clicks would be click 21's (it was), refused in one line.
    capsys.readouterr()
    assert main(["export", str(fitted_example), "--damper-table", str(tmp_path / "t"),
                 "--clicks", "10"]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert "trend rests on clicks 21-21 only" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "t" / "clicks_10.csv").exists()


def test_within_measured_stops_at_the_measured_velocities(
    fitted_example: Path, tmp_path: Path
) -> None:
    out = tmp_path / "tables"
    args = ["export", str(fitted_example), "--damper-table", str(out), "--within-measured"]
    assert main(args) == 0
    _, rows = _csv_rows(out / "clicks_00.csv")
    assert np.all(rows[:, 3] == 1)
    assert rows[0, 0] == pytest.approx(-PEAK_M_S * 1e3, rel=2e-3)  # the edges are rows
    assert rows[-1, 0] == pytest.approx(PEAK_M_S * 1e3, rel=2e-3)
    assert 0.0 in rows[:, 0] and 100.0 in rows[:, 0]
    curve = read_teimorbit((out / "clicks_00.dpr").read_text())
    assert np.max(np.abs(curve.velocity)) == pytest.approx(PEAK_M_S * 1e3, rel=2e-3)


def test_a_fit_without_the_span_marks_nothing_and_says_so(
    fit_json: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tables"
    assert main(["export", str(fit_json), "--damper-table", str(out), "--clicks", "0"]) == 0
    assert "clicks 0: the fit does not record the velocities" in capsys.readouterr().out
    assert main(["export", str(fit_json), "--damper-table", str(tmp_path / "w"),
                 "--within-measured"]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert "--within-measured" in err and "fit the recording again" in err
    assert err.count("\n") == 1 and not (tmp_path / "w").exists()


def test_the_friction_band_smooths_the_step_through_zero_and_nothing_else(
    tmp_path: Path,
) -> None:
    # The spec's own damper (35 N of friction, its sign smoothed over 1 mm/s): at 21 clicks
    # the .dpr steps to 35 N within 2.5 mm/s. With a 25 mm/s band the curve differs from
    # the plain one by exactly F_f (tanh(v / 25 mm/s) - tanh(v / 1 mm/s)).
    fit = tmp_path / "fit.json"
    FitResult.from_spec(SPEC, [21]).save(fit)
    plain, banded = tmp_path / "plain", tmp_path / "band"
    assert main(["export", str(fit), "--damper-table", str(plain)]) == 0
    args = ["export", str(fit), "--damper-table", str(banded), "--friction-band-mm-s", "25"]
    assert main(args) == 0
    a = read_teimorbit((plain / "clicks_21.dpr").read_text())
    b = read_teimorbit((banded / "clicks_21.dpr").read_text())
    assert np.array_equal(a.velocity, b.velocity)
    first = np.flatnonzero(a.velocity == 2.5)[0]
    assert a.force[first] > 34.0  # the step: friction alone is 34.5 N there
    assert b.force[first] < 6.0  # now a slope: 3.5 N of friction and the bleed's 1.6 N
    v = a.velocity * 1e-3
    friction = 35.0 * (np.tanh(v / 0.025) - np.tanh(v / 0.001))
    assert np.allclose(b.force - a.force, friction, atol=0.02)  # six significant digits
    fast = np.abs(a.velocity) >= 100
    assert np.allclose(b.force[fast], a.force[fast], atol=0.05)  # away from the band: the same
    assert "friction smoothed over 25 mm/s" in (banded / "clicks_21.dpr").read_text()
    for k, bad in enumerate(("0", "-5", "500", "nan")):
        out = tmp_path / f"refused{k}"
        assert (
            main(["export", str(fit), "--damper-table", str(out), "--friction-band-mm-s", bad]) == 2
        )
        assert not out.exists()
