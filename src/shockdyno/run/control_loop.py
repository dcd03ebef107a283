"""The session's control loop: the one loop that reads the DAQ (daq_stream.py: the limits
on every sample), feeds the drive's watchdog (heartbeat.py) and polls the drive's status
(watch.py: what it must keep), and every wait built on it.

Time: every wait is measured on the DAQ's clock (its sample counter), so a simulated rig
running N times faster finishes N times sooner. Only the guards for a frozen DAQ or a dead
link use the host's clock, since a stalled clock cannot time itself.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from shockdyno.errors import RigFault
from shockdyno.rig.actuator import ActuatorStatus, ModbusActuator
from shockdyno.rig.config import RigConfig
from shockdyno.rig.daq import READ_SIZE
from shockdyno.rig.frames import FRAME_LEN, STATUS_MOTION
from shockdyno.rig.types import Daq
from shockdyno.run.daq_stream import DaqStream
from shockdyno.run.heartbeat import LoopHeartbeat
from shockdyno.run.safety import SafetyEvent, SafetyTrip
from shockdyno.run.session_state import SessionState
from shockdyno.run.watch import DriveWatch
from shockdyno.samples import SampleBlock

# A command's round trip takes wall time, which a fast simulated rig turns into seconds of
# DAQ time: no DAQ-time deadline is called before this much host time has passed too.
MIN_WALL_S = 0.5
FULL_READ = READ_SIZE // FRAME_LEN - 2  # frames: a read this full means more is waiting

ActuatorSink = Callable[[float, dict[str, float | int | bool]], None]


class DaqBudget:
    """A wait's deadline on the DAQ clock, counted from the newest sample once the backlog
    is read (a command acts at the drive's present, which a host that fell behind has not
    read yet), with a host-time floor (MIN_WALL_S) from the same read. A short read is not
    proof that the backlog is gone (a starved simulated rig may not have handed the socket
    the rest yet): a full read after it starts both again. Loaded suite runs aborted a
    sine and a move whose start was still in the backlog."""

    def __init__(self, seconds: float, clock: Callable[[], float]) -> None:
        self.seconds = seconds
        self._clock = clock
        self._t_start = math.nan
        self._wall_start = math.nan

    def read(self, frames: int, t: float) -> None:
        """Note a read of `frames` frames that left the stream at DAQ time `t`."""
        if frames >= FULL_READ:
            self._t_start = math.nan
        elif math.isnan(self._t_start):
            self._t_start, self._wall_start = t, self._clock()

    def spent(self, t: float) -> bool:
        """Whether the wait's time is up at DAQ time `t` (s): its seconds on the DAQ clock since
        the backlog was read, and MIN_WALL_S of host time."""
        return t - self._t_start > self.seconds and self._clock() - self._wall_start > MIN_WALL_S


class ControlLoop:
    """The drive and the DAQ as the session reaches them: `actuator` and `daq` (None until
    connected), refused once the session is closed."""

    def __init__(self, rig: RigConfig, state: SessionState, clock: Callable[[], float]) -> None:
        self.rig = rig
        self.clock = clock
        self._state = state  # armed: a drive found disabled is a trip (watch.py)
        self.actuator: ModbusActuator | None = None
        self.daq: Daq | None = None
        self.stream = DaqStream(rig.daq, rig.limits, clock)  # the DAQ: clock, limits, sink
        self.heartbeat = LoopHeartbeat(self._beat, rig.heartbeat.period_s, clock)
        self.watch = DriveWatch()  # setpoints and state the drive must keep
        self.last_status: ActuatorStatus | None = None
        self.poll_rtt = 0.0  # host time the last status poll took
        self.last_poll_wall = -math.inf
        self.on_actuator: ActuatorSink | None = None

    def act(self) -> ModbusActuator:
        """The connected drive; RigFault when the session is not open (before connecting, or
        closed)."""
        if self.actuator is None or self._state.closed:
            raise RigFault("rig session is not open")
        return self.actuator

    def connected_daq(self) -> Daq:
        """The connected DAQ; RigFault when the session is not open (before connecting, or
        closed)."""
        if self.daq is None or self._state.closed:
            raise RigFault("rig session is not open")
        return self.daq

    def _beat(self) -> None:
        self.act().beat()

    def first_samples(self) -> None:
        """Wait (host clock: the DAQ clock is not yet known) for the first valid frames."""
        start = self.clock()
        while self.clock() - start < max(2.0, 4 * self.rig.daq.frozen_timeout_s):
            if len(self.pump(check=False)):
                return
        raise RigFault(f"DAQ {self.rig.daq.url}: no valid frames")

    def pump(self, check: bool) -> SampleBlock:
        """Read the DAQ once (daq_stream.py: the limits on every sample), then feed the
        drive's watchdog: only a loop that reads and checks keeps the drive alive. A beat
        that fails is a lost link (stopping, the stop's own requests will say so)."""
        block = self.stream.read(self.connected_daq, check)
        try:
            self.heartbeat.feed()
        except RigFault as exc:
            if check:
                raise SafetyTrip(
                    SafetyEvent(self.stream.t, "link_lost", f"lost link to actuator: {exc}")
                ) from None
        return block

    def check_present(self) -> None:
        """Read (limits checked) until a read brings samples and the backlog is gone: an
        empty read (none arrived in its few ms) would otherwise end a catch-up that checked
        nothing (a ram another master moved beyond the travel limit was enabled again)."""
        while not len(self.pump(check=True)):
            pass  # a DAQ that stays silent trips daq_frozen after daq.frozen_timeout_s
        self.catch_up(check=True)

    def catch_up(self, check: bool) -> None:
        """Read until the DAQ backlog is gone (e.g. after an operator prompt)."""
        for _ in range(10000):
            if len(self.pump(check)) < FULL_READ:
                return

    def poll(self, check: bool, force: bool = False) -> ActuatorStatus | None:
        """The drive's status, a poll period after the last (`force`: now); checking, a
        setpoint or a state the drive did not keep, or a fault, is a trip."""
        now = self.clock()
        if not force and now - self.last_poll_wall < self.rig.poll_period_s:
            return None
        self.last_poll_wall = now
        try:
            st = self.act().status(self.watch.setpoints)
        except RigFault as exc:
            if check:
                raise SafetyTrip(SafetyEvent(self.stream.t, "link_lost", str(exc))) from None
            raise
        self.poll_rtt = self.clock() - now
        self.last_status = st
        self.emit_actuator(st.fields())
        t = self.stream.t
        if check:
            self.watch.check_setpoints(st.setpoints, "at a status poll", t)
            self.watch.check_state(st, t, self._state.armed, self.stream.fresh)
        if check and st.fault:
            raise SafetyTrip(SafetyEvent(t, "actuator_fault", f"actuator fault: {st.fault_text}"))
        return st

    def emit_actuator(self, fields: dict[str, float | int | bool]) -> None:
        """Send the drive's fields to the recording's actuator channel (if one is attached),
        stamped with the DAQ time of the latest sample."""
        if self.on_actuator is not None:
            self.on_actuator(self.stream.t, fields)

    def wait(
        self,
        done: Callable[[ActuatorStatus], bool],
        *,
        daq_budget_s: float,
        what: str,
        check: bool = True,
    ) -> ActuatorStatus:
        """Pump and poll until done(status); budget on the DAQ clock (`DaqBudget`), guard
        on the host's."""
        self.catch_up(check)
        budget = DaqBudget(daq_budget_s, self.clock)
        budget.read(0, self.stream.t)  # the catch-up ended on a short read
        wall_start = self.clock()
        wall_guard = daq_budget_s * 2 + 5.0
        while True:
            budget.read(len(self.pump(check)), self.stream.t)
            st = self.poll(check)
            if st is not None and done(st):
                return st
            if budget.spent(self.stream.t):
                # Judge by a status read taken after the deadline, not one from before it
                # (at high sim speeds one poll period spans seconds of DAQ time).
                st = self.poll(check, force=True)
                if st is not None and done(st):
                    return st
                raise RigFault(f"{what}: not done within {daq_budget_s:.3g} s of DAQ time")
            if self.clock() - wall_start > wall_guard:
                raise RigFault(f"{what}: not done within {wall_guard:.3g} s")

    def wait_motion_start(self, budget_s: float) -> float:
        """DAQ time of the first sample with the drive's motion output set.

        The budget is `wait`'s (`DaqBudget`); the backlog before it is searched for the
        start all the same."""
        budget = DaqBudget(budget_s, self.clock)
        wall_start = self.clock()
        prev = False
        while True:
            block = self.pump(check=True)
            if len(block):
                bits = (block.status & STATUS_MOTION) != 0
                before = np.concatenate(([prev], bits[:-1]))
                rising = np.flatnonzero(bits & ~before)
                if rising.size:
                    return float(block.t_s[rising[0]])
                prev = bool(bits[-1])
            budget.read(len(block), self.stream.t)
            self.poll(check=True)
            waited = self.clock() - wall_start
            if budget.spent(self.stream.t) or waited > 2 * budget_s + 5:
                raise RigFault(
                    f"the drive did not start the sine (no motion output within {budget_s:g} s of "
                    f"DAQ time, {waited:.1f} s of host time)"
                )
