"""The actuator side of a session: enabling, ramps in hold mode, and the stop sequence
(the stop command first, then the ramp to centre and the disable), every step of which is
tried whatever failed before it.

Every wait goes through the control loop (control_loop.py), so the limits are checked
and the watchdog fed while the drive moves, stops or centres.
"""

from __future__ import annotations

from collections.abc import Callable

from shockdyno.errors import RigFault
from shockdyno.rig.actuator import ActuatorStatus
from shockdyno.rig.config import WATCHDOG_FAULT, RigConfig
from shockdyno.run.control_loop import ControlLoop
from shockdyno.run.daq_stream import BlockSink
from shockdyno.run.events import EventLog
from shockdyno.run.safety import SafetyEvent, SafetyTrip
from shockdyno.run.session_state import SessionState, State

CENTRE_TOLERANCE_M = 0.001
HOLD_TOLERANCE_M = 0.0005  # a hold has arrived when the DAQ's displacement is this close
# (loose enough for a servo's steady error under the gas load; the rest itself is found
# from the samples, run/gas_measure.py)


class DriveMotion:
    """The session's drive moves: enabling where the ram stands, hold-mode moves and holds, and
    the stop sequence (stop command, wait stopped, fault reset, centre, disable), each wait
    through the control loop."""

    def __init__(
        self, rig: RigConfig, loop: ControlLoop, state: SessionState, log: EventLog
    ) -> None:
        self.rig = rig
        self._loop = loop
        self._state = state
        self._log = log
        self.stop_sent = False  # the stop command went out since the last start or enable
        # A drive ramps a profile out over its stop time or one period, the longer: the
        # last profile's period (0: none yet) sizes the stop's wait.
        self.period_s = 0.0

    # -- enabling ------------------------------------------------------------------------
    def power_on(self) -> None:
        """Arm the drive's watchdog, reset faults, check the samples of now (limits), start
        the heartbeat and enable the drive where the ram is (enabling must not move it)."""
        act = self._loop.act()
        watchdog_ms = round(self.rig.heartbeat.timeout_s * 1000)
        act.write({"heartbeat_timeout_ms": watchdog_ms})
        got = int(act.read(["heartbeat_timeout_ms"])["heartbeat_timeout_ms"])
        if got == 0 or got > watchdog_ms:
            raise RigFault(
                f"drive watchdog reads {got} ms after writing {watchdog_ms} ms "
                f"({self.rig.source} heartbeat.timeout_s): refusing to enable a drive whose "
                "watchdog is off or longer than the rig file allows"
            )
        self._loop.watch.expect({"heartbeat_timeout_ms": float(watchdog_ms)})
        act.set_mode("hold")
        before = act.status()
        if before.fault:
            self._log.note("reset", f"fault before enabling, reset: {before.fault_text}")
        act.control("fault_reset", enable=False)
        st = act.status()
        if st.fault:
            raise RigFault(f"actuator fault will not reset: {st.fault_text}")
        self._loop.check_present()  # limits on samples of now, before the drive is on
        self._loop.heartbeat.start()
        act.write({"position_command": st.position_m})  # enabling must not move the ram
        act.control(enable=True)
        self.stop_sent = False
        self._loop.wait(lambda s: s.enabled, daq_budget_s=2.0, what="enable")

    # -- moves ---------------------------------------------------------------------------
    def move_to_centre(self, check: bool, seen: bool = False) -> None:
        """`seen`: also wait for the DAQ's samples to show the ram centred (not in a stop,
        where the DAQ may be what failed)."""
        stream = self._loop.stream
        settled = (lambda: abs(stream.x) < CENTRE_TOLERANCE_M) if seen else (lambda: True)
        distance, _ = self.move(
            self.rig.stroke_centre_m, check=check, what="ramp to centre", settled=settled
        )
        self._log.note("centre", f"at stroke centre ({distance * 1e3:.1f} mm ramp)")

    def move(
        self,
        target_m: float,
        *,
        check: bool,
        what: str,
        velocity_m_s: float | None = None,
        settled: Callable[[], bool] = lambda: True,
    ) -> tuple[float, ActuatorStatus]:
        """Ramp to the absolute position `target_m` at `velocity_m_s` (None: the rig's
        ramp.move_velocity_m_s): the distance ramped, the status on arrival. Arrival is the
        drive's, and `settled()` besides (a hold also waits for the DAQ's samples)."""
        act = self._loop.act()
        st = act.status()
        if not check and not st.enabled:
            # Disabled by someone else (a panel, an emergency stop, another master): this
            # session does not re-enable a drive behind their back to centre it.
            raise RigFault(
                f"the drive is disabled, not by this session: left at "
                f"{(st.position_m - self.rig.stroke_centre_m) * 1e3:+.1f} mm from centre, "
                "not re-enabled to centre it"
            )
        distance = abs(st.position_m - target_m)
        v = self.rig.ramp.move_velocity_m_s if velocity_m_s is None else velocity_m_s
        act.set_mode("hold")
        act.write({"move_velocity": v, "position_command": target_m})
        arrived = self._loop.wait(
            lambda s: (
                s.target_reached and abs(s.position_m - target_m) < CENTRE_TOLERANCE_M and settled()
            ),
            daq_budget_s=distance / v + 2.0,
            what=what,
            check=check,
        )
        return distance, arrived

    def hold(
        self, offset_m: float, velocity_m_s: float, dwell_s: float, on_block: BlockSink
    ) -> tuple[float, float]:
        """Move at `velocity_m_s` to `offset_m` from the stroke centre and hold still for
        `dwell_s` of DAQ time, every sample to `on_block`: the DAQ times (arrived, end of
        the hold). A trip or a fault makes the stop sequence and raises RigFault."""
        loop, stream = self._loop, self._loop.stream
        loop.act()  # not connected: refused here, before the stop a failed move makes
        try:
            # Unlike a sine's, the backlog goes to on_block: consecutive holds (the
            # gas-force measurement's) then stream every sample between them too.
            stream.on_block = on_block
            loop.catch_up(check=True)
            # Arrived when the drive says so and the DAQ's samples show it: at a fast
            # simulated rig's speed the stream lags the drive by a good part of a second.
            self.move(
                self.rig.stroke_centre_m + offset_m,
                check=True,
                what=f"move to {offset_m * 1e3:+g} mm",
                velocity_m_s=velocity_m_s,
                settled=lambda: abs(stream.x - offset_m) < HOLD_TOLERANCE_M,
            )
            arrived = stream.t
            loop.wait(lambda s: stream.t >= arrived + dwell_s, daq_budget_s=dwell_s + 2.0,
                      what="hold")  # fmt: skip
            return arrived, stream.t
        except RigFault as exc:
            raise RigFault(self.abort(exc).message) from None
        finally:
            stream.on_block = None

    # -- stopping ------------------------------------------------------------------------
    def halt(self) -> bool:
        """Put the controlled-stop command on the wire now, without waiting for anything
        (no event, no status read when a poll is fresh): the first request of every stop.
        Whether the stop has been sent (now or since the last start)."""
        loop = self._loop
        act = loop.actuator
        if act is None or self._state.closed:
            return False
        if self.stop_sent:
            return True
        st = loop.last_status
        # Fresh: about one poll old (on RTU a poll takes ~0.1 s: a read before the stop
        # would double the time to the stop)
        age = loop.clock() - loop.last_poll_wall
        fresh = st is not None and age < 4 * self.rig.poll_period_s + 2 * loop.poll_rtt
        try:
            # A drive someone else disabled stays disabled: the stop goes without the
            # enable bit, which would otherwise re-enable it.
            enabled = st.enabled if fresh and st is not None else act.status().enabled
            act.control("stop", enable=enabled)
        except RigFault:
            return False  # the stop sequence's own stop step tries again, and says why
        self.stop_sent = True
        return True

    def abort(self, exc: RigFault) -> SafetyEvent:
        """A motion that failed: the stop on the wire first, the bookkeeping after (the
        trip's event, or a fault's), then the stop sequence. The event that says why."""
        self.halt()
        if isinstance(exc, SafetyTrip):
            ev = self._log.record(exc.event)
        else:
            ev = self._log.note("fault", str(exc))
        self.safe_stop(ev.message)
        return ev

    def safe_stop(self, reason: str, then: State = State.IDLE) -> None:
        """Controlled stop, ramp to centre, disable (the session `then` idle, or parked).
        Every step is tried; none may raise."""
        sent = self.halt()
        self._log.note("stop", f"controlled stop: {reason}")
        steps: list[tuple[str, Callable[[], None]]] = [
            ("watchdog", self._restore_watchdog),
            ("stop", self._wait_stopped if sent else self._stop_motion),
            ("reset", self._reset_fault),
            ("centre", lambda: self.move_to_centre(check=False)),
        ]
        for name, step in steps:
            try:
                step()
            except RigFault as exc:
                self._log.note("stop_step_failed", f"{name}: {exc}")
                if name == "stop":
                    break  # a drive that will not stop must not be asked to move
        self.disable(reason, then)

    def _restore_watchdog(self) -> None:
        """If another master lengthened the watchdog, a host that dies mid-stop must still
        leave the drive to stop itself in the rig file's time."""
        ms = round(self.rig.heartbeat.timeout_s * 1000)
        self._loop.act().write({"heartbeat_timeout_ms": ms})

    def _stop_motion(self) -> None:
        act = self._loop.act()
        # A drive someone else disabled stays disabled: the stop goes without the enable
        # bit, which would otherwise re-enable it.
        act.control("stop", enable=act.status().enabled)
        self.stop_sent = True
        self._wait_stopped()

    def _wait_stopped(self) -> None:
        self._loop.wait(
            lambda s: not s.running,
            daq_budget_s=max(self.rig.ramp.stop_time_s, self.period_s) + 2.0,
            what="controlled stop",
            check=False,
        )

    def _reset_fault(self) -> None:
        act = self._loop.act()
        st = act.status()
        if not st.fault:
            return
        if st.fault_text == WATCHDOG_FAULT and st.enabled:
            # Its watchdog's fault reaction ends in a disable: a reset before it would
            # be overtaken by it (the ram cut off mid-ramp on the way to the centre).
            self._loop.wait(
                lambda s: not s.enabled, daq_budget_s=2.0, what="watchdog stop", check=False
            )
        self._log.note("reset", f"fault reset: {st.fault_text}")
        act.control("fault_reset")
        after = act.status()
        if after.fault:
            raise RigFault(f"fault will not reset: {after.fault_text}")

    def disable(self, reason: str, then: State = State.IDLE) -> None:
        """Disable the drive; the session is `then` (idle, or parked) after it, whatever
        the drive answers."""
        if not self._state.closed:
            self._state.to(then, reason)
        try:
            self._loop.act().control(enable=False)
            self._log.note("disable", "actuator disabled")
        except RigFault as exc:
            self._log.note("stop_step_failed", f"disable: {exc}")
        self._loop.heartbeat.stop()
