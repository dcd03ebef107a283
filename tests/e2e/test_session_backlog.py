"""A host slow to start (a loaded machine, a first call that compiles) against a fast rig."""

from __future__ import annotations

import time

from shockdyno.run.daq_stream import DaqStream
from shockdyno.run.session import RigSession
from shockdyno.samples import SampleBlock


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


def starve(monkeypatch, session: RigSession, method: str, stalls) -> None:  # type: ignore[no-untyped-def]
    """The host stalls 0.6 s before the actuator call `method` when `stalls(args)`, and
    then reads the DAQ slowly (50 ms a read, 73 k frames/s against the rig's 50 k): at 50x,
    30 s of samples to read through, more than a second of reads. The stall is shorter
    than the drive's watchdog (1 s in rigs/sim.toml): a loop that stalls longer stops the
    drive, as it must (test_contract_watchdog.py)."""
    cls = type(session.actuator)
    call, read = getattr(cls, method), DaqStream.read

    def late(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        if stalls(args):
            time.sleep(0.6)
        return call(self, *args, **kwargs)

    def slow_read(self, daq, check):  # type: ignore[no-untyped-def]
        time.sleep(0.05)
        return read(self, daq, check)

    monkeypatch.setattr(cls, method, late)
    monkeypatch.setattr(DaqStream, "read", slow_read)


def test_a_host_starved_before_it_commands_a_move_still_sees_the_move(
    sim_rig_factory, monkeypatch
) -> None:
    # A move's budget is DAQ time (a fast simulated rig's clock). A host held up between
    # its last read and the command, and slow to read after it (a loaded CI machine: "move
    # to -5 mm: not done within 2.25 s of DAQ time"), starts the move 30 s of samples after
    # its last read and takes more than MIN_WALL_S to read through them: the budget counts
    # from when the command could act, not from that last read.
    sim = sim_rig_factory(speed=50)
    with RigSession(sim.rig_config()) as session:
        starve(monkeypatch, session, "write", lambda args: "position_command" in args[0])
        got: list[SampleBlock] = []
        arrived, end = session.hold_at(-0.005, None, 0.2, got.append)
        monkeypatch.undo()
    x = SampleBlock.concat(got).displacement_m
    assert end - arrived >= 0.2 and abs(x[-1] + 0.005) < 0.0005


def test_a_host_starved_before_it_starts_a_sine_still_finds_the_start(
    sim_rig_factory, monkeypatch
) -> None:
    # The same stall before the start command: the drive starts the sine 30 s of samples
    # after the host's last read, and the host's one-second budget for the motion output
    # to rise must not be spent reading the samples from before it.
    sim = sim_rig_factory(speed=50)
    with RigSession(sim.rig_config()) as session:
        starve(monkeypatch, session, "control", lambda args: "start" in args)
        out = session.run_sine(0.01, 2.0, 0, 1, lambda block: None)
        monkeypatch.undo()
    assert out.status == "complete", out.reason


def test_a_drive_that_never_starts_the_sine_is_reported_within_its_budget(
    sim_rig_factory, monkeypatch
) -> None:
    # The start command lost on the way: the drive stays in hold, no motion output rises.
    sim = sim_rig_factory(speed=50)
    with RigSession(sim.rig_config()) as session:
        cls = type(session.actuator)
        control = cls.control

        def no_start(self, *commands, **kwargs):  # type: ignore[no-untyped-def]
            if "start" not in commands:
                control(self, *commands, **kwargs)

        monkeypatch.setattr(cls, "control", no_start)
        t0 = time.monotonic()
        out = session.run_sine(0.01, 2.0, 0, 1, lambda block: None)
        waited = time.monotonic() - t0
        monkeypatch.undo()
    assert out.status == "aborted"
    assert out.reason.startswith("the drive did not start the sine (no motion output within 1 s")
    assert waited < 7.0  # the DAQ budget's half-second floor, not the 7 s host-time cap
