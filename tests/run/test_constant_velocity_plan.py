"""Planning constant-velocity tests (issue 47): the plan, the records, the one-line refusals."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import pytest

from shockdyno.cli import main
from shockdyno.errors import ConfigError
from shockdyno.model.stroke import Stroke
from shockdyno.record import open_recording
from shockdyno.record.schemas import meta_from_json, meta_to_json
from shockdyno.record.types import TestMeta
from shockdyno.rig.config import load_rig
from shockdyno.run.plan import SweepPlan, constant_velocity_strokes, stroke_frequency_hz
from shockdyno.run.refusals import check_stroke

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "rigs" / "sim.toml"


def test_a_trapezoid_plan_gives_each_speed_its_period() -> None:
    strokes = constant_velocity_strokes("trapezoid", [0.025, 0.1], 0.03, None)
    # Default: each reversal takes the outer 10 % of the amplitude.
    assert [s.rounding_m for s in strokes] == pytest.approx([0.003, 0.003], rel=1e-3)
    plan = SweepPlan(clicks=(0,), frequencies_hz=tuple(stroke_frequency_hz(s) for s in strokes),
                     amplitude_m=0.03, strokes=tuple(strokes))  # fmt: skip
    assert plan.waveform == "trapezoid"
    assert plan.stroke(plan.frequencies_hz[1]) == strokes[1]
    assert plan.frequencies_hz[0] == pytest.approx(
        1 / (4 * 0.03 / 0.025 + 2 * 0.025 / strokes[0].accel_m_s2), rel=1e-4
    )
    assert SweepPlan(clicks=(0,)).stroke(1.0) is None


def test_a_sine_record_keeps_its_keys_and_an_old_record_reads_as_a_sine() -> None:
    sine = TestMeta(index=0, clicks=3, gas_clicks=0, frequency_hz=1.0, amplitude_m=0.03,
                    sample_rate_hz=1000.0)  # fmt: skip
    new = {"target_velocity_m_s", "reversal_accel_m_s2", "adjusters"}  # written when set
    assert set(meta_to_json(sine)) == {f.name for f in fields(TestMeta)} - new
    old = {k: v for k, v in meta_to_json(sine).items() if k != "motion"}
    back = meta_from_json(old)
    assert back.motion == "sine" and back.target_velocity_m_s is None
    cv = TestMeta(index=0, clicks=3, gas_clicks=0, frequency_hz=0.5, amplitude_m=0.03,
                  sample_rate_hz=1000.0, motion="triangle", target_velocity_m_s=0.06)  # fmt: skip
    assert meta_from_json(meta_to_json(cv)) == cv


def test_the_drive_refuses_what_it_cannot_do_before_moving() -> None:
    rig = load_rig(SIM_RIG)
    check_stroke(rig, Stroke("trapezoid", 0.03, 0.1, 2.0), 50.0)  # fine
    with pytest.raises(ConfigError, match="exceeds the drive's acceleration_limit"):
        check_stroke(rig, Stroke("trapezoid", 0.03, 0.3, 60.0), 50.0)
    with pytest.raises(ConfigError, match="under 50% of it at constant velocity"):
        check_stroke(rig, Stroke("trapezoid", 0.01, 0.3, 5.0), 50.0)
    # A triangle's sharp reversal, at the drive's best, carries the ram past the travel.
    with pytest.raises(ConfigError, match="past the rig's travel"):
        check_stroke(rig, Stroke("triangle", 0.044, 0.5), 50.0)
    check_stroke(rig, Stroke("triangle", 0.03, 0.5), 50.0)
    sines_only = REPO / "rigs" / "example-servo-hydraulic.toml"
    with pytest.raises(ConfigError, match="this drive runs sines only"):
        check_stroke(load_rig(sines_only), Stroke("triangle", 0.03, 0.1), 50.0)


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--waveform", "triangle"], "is planned by speed: give --velocities-mm-s"),
        (["--waveform", "triangle", "--freq", "1"], "planned by speed"),
        (["--velocities-mm-s", "50", "--reversal-accel-m-s2", "2"],
         "--reversal-accel-m-s2 applies to --waveform trapezoid only"),
        (["--waveform", "triangle", "--velocities-mm-s", "590"], "95 % of the rig's limit"),
    ],
)  # fmt: skip
def test_combinations_that_make_no_sense_are_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], said: str
) -> None:
    out = tmp_path / "never.mcap"
    code = main(["sweep", "--rig", str(SIM_RIG), "--clicks", "0", *args, "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert said in err and err.count("\n") == 1, err
    assert not out.exists()


def test_a_reversal_beyond_the_drive_is_refused_before_enabling(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The drive's acceleration_limit is read over Modbus before the drive is enabled: a
    trapezoid asking more is one line, and no recording is left behind."""
    out = tmp_path / "never.mcap"
    args = ["sweep", "--rig", str(SIM_RIG), "--start-sim", "--speed", "20", "--clicks", "0"]
    args += ["--waveform", "trapezoid", "--velocities-mm-s", "300", "--reversal-accel-m-s2", "80"]
    assert main([*args, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "exceeds the drive's acceleration_limit of 50 m/s²" in err and err.count("\n") == 1
    assert not out.exists()


def test_an_imported_triangle_needs_its_speed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "t.csv"
    data.write_text("time_s,displacement_m,force_N\n" + "".join(
        f"{i / 1000},{0.0001 * (i % 50)},{i % 7}\n" for i in range(200)))  # fmt: skip
    manifest = tmp_path / "manifest.csv"
    manifest.write_text("file,clicks,frequency_hz,amplitude_m,motion\nt.csv,3,1.0,0.03,triangle\n")
    out = tmp_path / "r.mcap"
    assert main(["import", str(manifest), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "a triangle test needs its target_velocity_m_s column" in err
    assert err.count("\n") == 1 and not out.exists()
    manifest.write_text(
        "file,clicks,frequency_hz,amplitude_m,motion,target_velocity_m_s\n"
        "t.csv,3,1.0,0.03,triangle,0.12\n"
    )
    assert main(["import", str(manifest), "-o", str(out)]) == 0
    (test,) = open_recording(out).load_all()
    assert (test.meta.motion, test.meta.target_velocity_m_s) == ("triangle", 0.12)
