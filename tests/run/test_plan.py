"""Sweep plan parsing and ordering."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from shockdyno.cli import main
from shockdyno.errors import ConfigError
from shockdyno.lists import parse_clicks, parse_floats, parse_frequencies, parse_letters
from shockdyno.run.plan import (
    SweepPlan,
    frequencies_for_velocities,
    parse_adjust,
    parse_base,
    parse_velocities_mm_s,
)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("0-21", list(range(22))),
        ("0-21:3", [0, 3, 6, 9, 12, 15, 18, 21]),
        ("5,10,15", [5, 10, 15]),
        ("0-2,10,20-21", [0, 1, 2, 10, 20, 21]),
        ("3,3,1", [1, 3]),
        ("0-4,10,15-21:2", [0, 1, 2, 3, 4, 10, 15, 17, 19, 21]),
        (" 0 - 21 : 7 ".replace(" ", ""), [0, 7, 14, 21]),
    ],
)
def test_parse_clicks(text, expected):
    assert parse_clicks(text) == expected


@pytest.mark.parametrize(
    "text", ["", "a-b", "5-2", "0-22", "0-21:0", "-1", "1.5", "0,,3", "0-21:x"]
)
def test_bad_clicks_are_refused_in_one_line(text):
    with pytest.raises(ConfigError) as exc:
        parse_clicks(text)
    assert "\n" not in str(exc.value)


def test_parse_frequencies():
    assert parse_frequencies("0.5,1,1.5") == [0.5, 1.0, 1.5]
    assert parse_frequencies("0.5-2:0.5") == [0.5, 1.0, 1.5, 2.0]
    assert parse_frequencies("0.1-0.3:0.1,5") == [0.1, 0.2, 0.3, 5.0]  # no 0.30000000000000004
    for bad in ("", "x", "0", "-1", "nan", "1e9", "0.5-2", "2-1:0.5", "1-2:0"):
        with pytest.raises(ConfigError) as exc:
            parse_frequencies(bad)
        assert "\n" not in str(exc.value) and "--freq" in str(exc.value)


def test_every_list_flag_names_itself_in_its_error():
    with pytest.raises(ConfigError, match=r"^--speeds-kmh: cannot read 'fast'"):
        parse_floats("20,fast", "--speeds-kmh")
    assert parse_letters("A-C,e", "--roads") == ["A", "B", "C", "E"]
    with pytest.raises(ConfigError, match="--roads"):
        parse_letters("C-A", "--roads")


def test_plan_orders_clicks_outer_and_skips_done_points():
    plan = SweepPlan(clicks=(0, 5), frequencies_hz=(0.5, 1.5))
    keys = [p.key for p in plan.points()]
    assert keys == [(0, 0, 0.5, ()), (0, 0, 1.5, ()), (5, 0, 0.5, ()), (5, 0, 1.5, ())]
    left = plan.remaining({(0, 0, 0.5, ()), (0, 0, 1.5, ())})
    assert [p.key for p in left] == [(5, 0, 0.5, ()), (5, 0, 1.5, ())]


RANGES = {"compression": 20, "rebound": 20}


def test_one_at_a_time_moves_each_adjuster_from_the_base() -> None:
    adjust = parse_adjust(["rebound=0,10,20", "compression=0-20:10"], RANGES)
    assert adjust == (("compression", (0, 10, 20)), ("rebound", (0, 10, 20)))  # spec's order
    plan = SweepPlan(clicks=(), frequencies_hz=(1.0,), adjust=adjust)
    assert plan.base() == (("compression", 10), ("rebound", 10))
    got = [dict(s) for s in plan.settings()]
    assert got == [
        {"compression": 10, "rebound": 10},
        {"compression": 0, "rebound": 10},
        {"compression": 20, "rebound": 10},
        {"compression": 10, "rebound": 0},
        {"compression": 10, "rebound": 20},
    ]
    # a test's `clicks` is the first adjuster's, for readers of one
    assert [p.clicks for p in plan.points()] == [10, 0, 20, 10, 10]


def test_factorial_visits_every_combination_and_resume_skips_by_setting() -> None:
    adjust = parse_adjust(["compression=0,20", "rebound=0,5,20"], RANGES)
    plan = SweepPlan(clicks=(), frequencies_hz=(0.5, 1.0), adjust=adjust, design="factorial")
    points = plan.points()
    assert len(points) == 2 * 3 * 2
    assert len({p.key for p in points}) == len(points)
    # done: the first setting at both frequencies, keyed as the reader gives them
    done = {(0, 0, f, (("compression", 0), ("rebound", 0))) for f in (0.5, 1.0)}
    left = plan.remaining(done)
    assert len(left) == 10 and dict(left[0].adjusters) == {"compression": 0, "rebound": 5}


@pytest.mark.parametrize(
    ("items", "message"),
    [
        (["compression=0-20"], "give each"),
        (["compression=0-21", "rebound=0"], "clicks must be 0-20, got 21"),
        (["hs=1", "rebound=0"], "no adjuster 'hs'"),
        (["compression", "rebound=0"], "use NAME=CLICKS"),
        (["compression=1", "compression=2", "rebound=0"], "given twice"),
        (["compression=1.5", "rebound=0"], "cannot read"),
    ],
)
def test_bad_adjust_is_one_line(items: list[str], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_adjust(items, RANGES)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"amplitude_m": 0.0},
        {"amplitude_m": float("nan")},
        {"measured_cycles": 0},
        {"warmup_cycles": -1},
        {"temperature_band_c": (50.0, 40.0)},
    ],
)
def test_absurd_plans_are_refused(kwargs):
    with pytest.raises(ConfigError):
        SweepPlan(clicks=(0,), **kwargs)


def test_frequencies_for_target_velocities_reach_them():
    velocities = parse_velocities_mm_s("300, 25,50,100,200,50")
    assert velocities == [0.025, 0.05, 0.1, 0.2, 0.3]
    freqs = frequencies_for_velocities(velocities, 0.030)
    reached = [2 * math.pi * f * 0.030 for f in freqs]
    # Each target exactly, but the fastest 10 % faster: a sine planned at exactly it would
    # only touch it at its peak, and the servo's tracking leaves the peak short.
    assert reached[:-1] == pytest.approx(velocities[:-1], rel=5e-5)
    assert reached[-1] == pytest.approx(0.33, rel=5e-5)
    assert freqs[0] == pytest.approx(0.13263, abs=1e-5)  # 25 mm/s at 30 mm: 7.5 s a cycle
    # The margin stops at the rig's limit, and never plans under the target itself.
    capped = frequencies_for_velocities([0.1, 0.3], 0.030, max_velocity_m_s=0.31)
    assert 2 * math.pi * capped[-1] * 0.030 == pytest.approx(0.31, rel=5e-5)
    at_limit = frequencies_for_velocities([0.3], 0.030, max_velocity_m_s=0.29)
    assert 2 * math.pi * at_limit[0] * 0.030 == pytest.approx(0.3, rel=5e-5)


@pytest.mark.parametrize("text", ["", "25,x", "0", "-25", "nan"])
def test_bad_velocities_are_refused_in_one_line(text):
    with pytest.raises(ConfigError) as exc:
        parse_velocities_mm_s(text)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--velocities-mm-s", "25,700"], "700 mm/s exceeds 570 mm/s, 95 % of the rig's limit"),
        # at the limit itself: refused here, not by the session after the rig is started
        (["--velocities-mm-s", "600"], "600 mm/s exceeds 570 mm/s, 95 % of the rig's limit"),
        (["--velocities-mm-s", "0.001"], "a cycle of 52.4 h"),
        (["--velocities-mm-s", ""], "velocities must be > 0 mm/s"),
        (["--velocities-mm-s", "500", "--amplitude-mm", "0.5"], "above the 50 Hz"),
        (["--velocities-mm-s", "25", "--freq", "1"], "not allowed with argument"),
    ],
)
def test_sweep_by_velocity_beyond_the_rig_is_refused_before_anything_runs(
    tmp_path, capsys, extra, message
):
    out = tmp_path / "never.mcap"
    rig = Path(__file__).resolve().parents[2] / "rigs" / "sim.toml"
    try:
        code = main(["sweep", "--rig", str(rig), "--start-sim", "-o", str(out), *extra])
    except SystemExit as exc:  # argparse's own usage error
        code = int(str(exc.code))
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and "Traceback" not in err
    assert not out.exists()


def test_base_holds_the_others_where_given() -> None:
    adjust = parse_adjust(["compression=0-20:10", "rebound=0,10,20"], RANGES)
    held = parse_base(["rebound=20"], RANGES)
    plan = SweepPlan(clicks=(), frequencies_hz=(1.0,), adjust=adjust, held=held)
    assert plan.base() == (("compression", 10), ("rebound", 20))
    assert [dict(s)["rebound"] for s in plan.settings()[:3]] == [20, 20, 20]
    with pytest.raises(ConfigError, match="--base goes with --design one-at-a-time"):
        SweepPlan(clicks=(), adjust=adjust, held=held, design="factorial")
    for bad, message in (("hs=1", "use NAME=CLICKS"), ("rebound=x", "not a whole number"),
                         ("rebound=21", "clicks must be 0-20")):  # fmt: skip
        with pytest.raises(ConfigError, match=message):
            parse_base([bad], RANGES)
