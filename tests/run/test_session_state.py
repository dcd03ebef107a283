"""The session's state machine (run/session_state.py): a call its state does not allow is
refused before anything reaches the drive, and the teardown from every state leaves the
ram stopped, centred and disabled. The rig tests run on the simulated rig over its real
Modbus server and serial stream."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest

from shockdyno.rig.actuator import ActuatorStatus, ModbusActuator
from shockdyno.rig.config import RigConfig
from shockdyno.rig.frames import STATUS_MOTION
from shockdyno.run.session import RigSession
from shockdyno.run.session_state import ALLOWED, TRANSITIONS, SessionState, State, StateError
from shockdyno.samples import SampleBlock


def test_every_state_reaches_closed_and_nothing_leaves_it() -> None:
    for state in State:
        if state is not State.CLOSED:
            assert State.CLOSED in TRANSITIONS[state], state
            assert State.IDLE in TRANSITIONS[state], state  # a stop may come from anywhere
    assert TRANSITIONS[State.CLOSED] == frozenset()
    assert all(State.CLOSED not in states for states in ALLOWED.values())


def test_a_motion_is_allowed_only_when_enabled() -> None:
    s = SessionState()
    with pytest.raises(StateError, match=r"^run_sine refused: the actuator is not enabled yet$"):
        s.require("motion", "run_sine")
    s.to(State.ENABLED)
    with s.moving("run_sine"):
        assert s.state is State.MOVING and s.armed
        with pytest.raises(StateError, match="hold_at refused: a motion is running"):
            s.require("motion", "hold_at")
    assert s.state is State.ENABLED
    s.to(State.PARKED, "waiting for the operator")
    with pytest.raises(StateError, match=r"not enabled: parked \(waiting for the operator\)"):
        s.require("motion", "dwell")
    with pytest.raises(StateError, match="no transition from parked to moving"):
        s.to(State.MOVING)


def test_an_exception_out_of_a_motion_leaves_only_the_close() -> None:
    s = SessionState()
    s.to(State.ENABLED)
    with pytest.raises(KeyboardInterrupt), s.moving("run_sine"):
        raise KeyboardInterrupt
    assert s.state is State.MOVING and s.armed  # the teardown must stop, centre, disable
    for kind in ALLOWED:
        with pytest.raises(StateError, match="only the close"):
            s.require(kind, kind)
    s.to(State.CLOSED, "operator interrupt (Ctrl-C)")
    with pytest.raises(StateError, match=r"enable refused: the rig session is closed \(operator"):
        s.require("enable", "enable")
    with pytest.raises(StateError, match="no transition from closed to enabled"):
        s.to(State.ENABLED)


def _status(rig: RigConfig) -> ActuatorStatus:
    """The drive as a fresh client sees it, once it has finished any stop."""
    act = ModbusActuator(rig)
    act.connect()
    try:
        end = time.monotonic() + 5.0
        st = act.status()
        while (st.running or st.enabled) and time.monotonic() < end:
            time.sleep(0.05)
            st = act.status()
        return st
    finally:
        act.close()


def _moving_for(seconds: float, then: Callable[[], None]) -> Callable[[SampleBlock], None]:
    """An on_block that calls `then` once the motion output has been up `seconds` of DAQ
    time."""
    start: list[float] = []
    done: list[bool] = []

    def on_block(block: SampleBlock) -> None:
        moving = np.flatnonzero(block.status & STATUS_MOTION)
        if not start and moving.size:
            start.append(float(block.t_s[moving[0]]))
        if start and not done and len(block) and block.t_s[-1] >= start[0] + seconds:
            done.append(True)
            then()

    return on_block


def test_calls_a_state_refuses_send_nothing_to_the_drive(sim_rig_factory) -> None:
    sim = sim_rig_factory(speed=20.0)
    rig = replace(sim.rig_config(), adjuster="operator")
    asked: list[str] = []
    never = RigSession(rig, prompt=asked.append)
    with pytest.raises(StateError, match="run_sine refused: the actuator is not enabled yet"):
        never.run_sine(0.01, 2.0, 0, 1, lambda b: None)
    with RigSession(rig, prompt=asked.append) as session:
        with pytest.raises(StateError, match="entering the session refused: it is open already"):
            session.__enter__()
        assert session.state is State.ENABLED
        with session.parked("the damper's temperature"):
            words, events = len(sim.registers.control_log), len(session.events)
            assert session.state is State.PARKED and not session.enabled
            with pytest.raises(
                StateError, match=r"parked \(waiting for the damper's temperature\)"
            ):
                session.run_sine(0.01, 2.0, 0, 1, lambda b: None)
            with pytest.raises(StateError, match="move_to refused"):
                session.move_to(0.002)
            with pytest.raises(StateError, match="set_clicks refused"):
                session.set_clicks(3, 0)
            assert asked == []  # no one asked to turn a knob the session would not wait for
            assert len(sim.registers.control_log) == words  # not a control word sent
            assert len(session.events) == events
        assert session.state is State.ENABLED  # enabled again after the wait
    assert session.state is State.CLOSED
    for call in (
        session.enable,
        session.read_temperature_c,
        lambda: session.set_clicks(3, 0),
        lambda: session.hold_at(0.0, None, 0.1, lambda b: None),
        session.__enter__,
    ):
        with pytest.raises(StateError, match=r"refused: .*closed"):
            call()
    assert asked == [] and session.events[-1].kind == "closed"


def _to_idle(session: RigSession, rig: RigConfig) -> None:
    """Another master rewrites the sine's frequency: the controlled stop disarms."""
    rogue = ModbusActuator(rig)
    rogue.connect()
    try:
        rewrite = _moving_for(0.3, lambda: rogue.write({"sine_frequency": 3.0}))
        out = session.run_sine(0.01, 2.0, 1, 2, rewrite)
    finally:
        rogue.close()
    assert out.status == "aborted" and "another Modbus master" in out.reason


def _to_moving(session: RigSession, rig: RigConfig) -> None:
    """Ctrl-C in the middle of a sine, as the signal handler raises it."""

    def interrupt() -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        session.run_sine(0.01, 2.0, 1, 2, _moving_for(0.3, interrupt))


def _to_parked(session: RigSession, rig: RigConfig) -> None:
    """Ctrl-C while the operator is asked for something."""
    with pytest.raises(KeyboardInterrupt), session.parked("the operator"):
        raise KeyboardInterrupt


@pytest.mark.parametrize(
    ("reach", "state", "stops"),
    [
        (lambda session, rig: None, State.ENABLED, True),
        (_to_idle, State.IDLE, False),
        (_to_moving, State.MOVING, True),
        (_to_parked, State.PARKED, False),
    ],
    ids=["enabled", "idle", "moving", "parked"],
)
def test_the_teardown_from_each_state_leaves_the_ram_stopped_centred_and_disabled(
    sim_rig_factory, reach, state, stops
) -> None:
    sim = sim_rig_factory(speed=20.0)
    rig = sim.rig_config()
    with RigSession(rig) as session:
        reach(session, rig)
        assert session.state is state
    assert session.state is State.CLOSED
    st = _status(rig)
    assert not st.enabled and not st.running and not st.fault
    assert st.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)
    kinds = [e.kind for e in session.events]
    after = kinds[kinds.index("exit") :]
    # Held enabled (or moving): the stop sequence; else the drive is already stopped and
    # centred by the stop before, and the teardown disables it.
    expected = (
        ["exit", "stop", "centre", "disable", "closed"] if stops else ["exit", "disable", "closed"]
    )
    assert after == expected, kinds
    assert "stop_step_failed" not in kinds
