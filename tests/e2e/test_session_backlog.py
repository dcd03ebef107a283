"""A host slow to start (a loaded machine, a first call that compiles) against a fast rig."""

from __future__ import annotations

import time

from shockdyno.rig.types import SampleBlock
from shockdyno.run.session import RigSession


def test_samples_from_before_the_session_centred_the_ram_are_not_the_first_holds(
    sim_rig_factory, monkeypatch
) -> None:
    # The simulated rig parks its ram 10 mm below centre. Half a second of wall time
    # before enabling is 20 s of samples at 40x: the drive says "centred" long before the
    # host has read them. A CI run recorded them with the first gas-force hold (its
    # outside-test samples spanned 11.3 mm, not the hold's 10).
    sim = sim_rig_factory(speed=40)
    enable = RigSession.enable

    def late_enable(self: RigSession) -> None:
        time.sleep(0.5)
        enable(self)

    monkeypatch.setattr(RigSession, "enable", late_enable)
    got: list[SampleBlock] = []
    with RigSession(sim.rig_config()) as session:
        assert abs(session._stream.x) < 0.001  # the session's eyes agree with the drive
        session.hold_at(0.005, None, 0.2, got.append)
    x = SampleBlock.concat(got).displacement_m
    assert x.min() > -0.0005 and x.max() < 0.0055  # centre to +5 mm, nothing of the park
