"""A sweep planned long says about how long before the rig moves (issue 48's new-user
review: `sweep --cycles 100000` started with no word of its days of motion); a short one
says nothing more than before."""

from __future__ import annotations

from pathlib import Path

import pytest

from rig_files import rig_on_closed_ports
from shockdyno.cli import main
from shockdyno.run.plan import SweepPlan, duration_text


def test_a_tests_motion_is_its_cycles_over_its_frequency() -> None:
    """At f Hz a cycle lasts 1/f s: 2 ramp + 2 warm-up + 100 measured cycles at 0.5 Hz
    are 208 s, at 2 Hz 52 s, and a sweep is the sum of its tests."""
    plan = SweepPlan(clicks=(0, 5), frequencies_hz=(0.5, 2.0), warmup_cycles=2,
                     measured_cycles=100)  # fmt: skip
    assert plan.motion_s(1, plan.points()[:1]) == pytest.approx(208.0)
    assert plan.motion_s(1, plan.points()) == pytest.approx(2 * (208.0 + 52.0))
    assert plan.motion_s(3, plan.points()[1:2]) == pytest.approx((6 + 2 + 100) / 2.0)


def test_a_duration_reads_as_a_person_says_it() -> None:
    assert duration_text(12 * 60) == "12 min"
    assert duration_text(3 * 3600 + 20 * 60 + 10) == "3 h 20 min"
    assert duration_text(2 * 86400 + 7 * 3600 + 59) == "2 d 7 h"


def test_a_long_sweep_says_how_long_before_it_starts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rig = rig_on_closed_ports(tmp_path)
    args = ["sweep", "--rig", str(rig), "--clicks", "0", "--freq", "1"]
    # 1 test of 100 004 cycles at 1 Hz (one ramp cycle each way, 2 warm-up): 27 h 47 min.
    assert main([*args, "--cycles", "100000", "-o", str(tmp_path / "long.mcap")]) == 3
    out = capsys.readouterr()
    said = [line for line in out.out.splitlines() if "of motion" in line]
    assert len(said) == 1, out.out
    assert "1 test of 2 warm-up and 100000 measured cycles: about 1 d 3 h of motion" in said[0]
    assert "Ctrl-C stops safely" in said[0]
    assert "cannot connect" in out.err  # said before the rig was asked for
    # 5 cycles: 9 s of motion, well under the 10 minutes: nothing more than before.
    assert main([*args, "--cycles", "5", "-o", str(tmp_path / "short.mcap")]) == 3
    assert "of motion" not in capsys.readouterr().out
