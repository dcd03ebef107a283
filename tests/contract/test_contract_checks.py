"""What a session checks before it enables the drive (issue 46.2): the DAQ's frame rate
against the rate the rig file states, and the rig file's trips against the drive's own
limits. A refusal leaves the drive as it was: never enabled."""

from __future__ import annotations

from dataclasses import replace

import pytest

from shockdyno.errors import ConfigError
from shockdyno.run.session import RigSession


@pytest.mark.parametrize(
    ("speed", "stated_hz", "words"),
    [
        # 50 Hz stated on a 1 kHz DAQ: velocities would read 20x low (the controlled stop
        # failed and the drive was disabled mid-motion at +3.5 mm).
        (4.0, 50.0, "the rig file says 200 ("),
        (1.0, 5000.0, "the rig file says 5000 ("),  # a DAQ slower than stated
    ],
)
def test_a_daq_rate_the_rig_file_misstates_is_refused_before_enabling(
    sim_rig_factory, speed: float, stated_hz: float, words: str
) -> None:
    sim = sim_rig_factory(speed=speed)
    rig = sim.rig_config()
    wrong = replace(rig, daq=replace(rig.daq, sample_rate_hz=stated_hz))
    with pytest.raises(ConfigError, match="refused before enabling") as exc:
        RigSession(wrong).__enter__()
    assert words in str(exc.value) and "daq.sample_rate_hz" in str(exc.value)
    assert not any(word & 1 for _, word in sim.registers.control_log)  # never enabled


def test_the_real_rate_passes_and_is_recorded(sim_rig_factory) -> None:
    sim = sim_rig_factory(speed=4.0)
    with RigSession(sim.rig_config()) as session:
        pass
    connect = next(e.message for e in session.events if e.kind == "connect")
    rate = float(connect.split("(")[1].split(" frames/s")[0])
    assert 4000 / 1.25 <= rate <= 4000 * 1.25  # 1 kHz at 4x


def test_limits_beyond_the_drives_own_are_refused_before_enabling(sim_rig_factory) -> None:
    sim = sim_rig_factory(speed=4.0)
    rig = sim.rig_config()
    # 49 mm of travel trips at 51.45 mm with the margin: beyond the drive's own 50 mm.
    wide = replace(rig, limits=replace(rig.limits, travel_m=0.049))
    with pytest.raises(ConfigError, match=r"beyond the drive's own travel_limit of 0\.05"):
        RigSession(wide).__enter__()
    assert not any(word & 1 for _, word in sim.registers.control_log)
