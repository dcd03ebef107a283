"""The gas-force measurement's refusals (before anything moves) and its verdict on the rests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from shockdyno.errors import ConfigError, RigFault
from shockdyno.rig.config import load_rig
from shockdyno.run.gas_measure import MAX_HYSTERESIS_N, GasMeasurement, rest_force
from shockdyno.run.session import RigSession
from shockdyno.samples import SampleBlock

SIM = Path(__file__).resolve().parents[2] / "rigs" / "sim.toml"


@pytest.mark.parametrize(
    ("offset", "velocity", "dwell", "message"),
    [
        (0.050, 0.004, 0.5, "exceeds the rig's travel of ±45 mm"),
        (0.005, 0.5, 0.5, "at most the rig's move velocity 0.02 m/s"),
        (0.005, 0.004, 0.0, "dwell must be > 0 s"),
        (float("nan"), 0.004, 0.5, "offset must be a finite number"),
    ],
)
def test_a_hold_the_rig_must_not_make_is_refused(offset, velocity, dwell, message) -> None:
    session = RigSession(load_rig(SIM))  # never entered: nothing is connected or moved
    with pytest.raises(ConfigError, match=message):
        session.hold_at(offset, velocity, dwell, lambda block: None)


def test_a_hold_needs_an_enabled_drive() -> None:
    with pytest.raises(RigFault, match="not enabled"):
        RigSession(load_rig(SIM)).hold_at(0.0, 0.004, 0.5, lambda block: None)


def test_rests_far_apart_are_not_a_gas_force() -> None:
    # Seal friction (stiction scenario: 60 N breakaway) holds either way at rest and cancels
    # in the mean; oil trapped behind shut valves (+643 / -504 N seen with aerated oil at
    # click 0) is no gas force.
    friction = GasMeasurement(230.0, 290.0, 170.0, 1.0)
    assert friction.usable and friction.hysteresis_n == 60.0
    trapped = GasMeasurement(69.5, 643.0, -504.0, 1.0)
    assert not trapped.usable and trapped.hysteresis_n > MAX_HYSTERESIS_N
    assert "not used" in trapped.message() and "not used" not in friction.message()


def test_the_rest_starts_when_the_samples_stop_moving_not_when_the_drive_says() -> None:
    # A fast simulated rig's samples lag the drive: told "arrived" at 0.8 s, the stream
    # still shows the ram coming in at 4 mm/s until 1.0 s, with a shut bleed's -280 N of
    # rebound damping on top of the 230.7 N gas force. (A demo run averaged that in:
    # 110.5 N at rest after rebound.)
    t = np.arange(0.0, 1.6, 1e-3)
    moving = t < 1.0
    x = np.where(moving, 0.004 * (1.0 - t), 0.0)
    force = np.where(moving, 230.7 - 280.0, 230.7)
    n = t.size
    block = SampleBlock(np.arange(n), t, x, force, np.full(n, 40.0), np.zeros(n, np.uint16))
    assert rest_force([block], 0.8, 1.6) == pytest.approx(230.7, abs=1e-9)
    # Too short a rest is an error, not a number.
    with pytest.raises(RigFault, match="samples at rest"):
        rest_force([block.slice(0, 1100)], 0.8, 1.1)
