"""RigSession: the one place safety lives. The sweep runner talks to a rig only through it.

    with RigSession(load_rig("rigs/sim.toml")) as rig:
        rig.set_clicks(10, 0)
        outcome = rig.run_sine(0.03, 1.5, warmup_cycles=2, measured_cycles=5, on_block=rec)

Entering connects the drive (Modbus) and the DAQ (pyserial URL), checks the drive's own
limits against the rig file's and the DAQ's frame rate against its stated rate, resets
faults, enables and ramps to the stroke centre. Leaving, whatever the reason (normal end,
exception, Ctrl-C, fault), sends the stop command first, then ramps to the centre,
disables and closes both transports; the reason goes to `events`.

The drive's watchdog is fed by the loop that reads the samples and checks the limits
(control_loop.py, heartbeat.py), never by a thread of its own: a blocked main thread
leaves the drive to stop itself. Before a wait on a person (the operator's clicks, the
damper's temperature) the drive is disabled, and enabled again after it.

The session is the state machine (session_state.py: idle, enabled, moving, parked,
closed; a call its state does not allow is refused before anything is sent); its parts
live beside it: the control loop (control_loop.py: the DAQ stream with the limits on
every sample, the heartbeat, the drive's status polls, every wait on the DAQ clock), the
actuator's moves and stop sequence (drive_motion.py), the checks before enabling
(preflight.py), a test's sine or stroke (sine_run.py) and the event log (events.py).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from types import TracebackType
from typing import ParamSpec, TypeVar

import numpy as np

from shockdyno import priority
from shockdyno.errors import ConfigError, RigFault
from shockdyno.model.stroke import Stroke
from shockdyno.rig.actuator import ActuatorStatus, ModbusActuator
from shockdyno.rig.config import DaqConfig, RigConfig
from shockdyno.rig.daq import SerialDaq
from shockdyno.rig.types import Daq
from shockdyno.run import preflight, signals
from shockdyno.run.control_loop import ActuatorSink, ControlLoop
from shockdyno.run.daq_stream import BlockSink
from shockdyno.run.drive_motion import DriveMotion
from shockdyno.run.events import EventLog, EventSink
from shockdyno.run.refusals import check_hold, check_sine, check_stroke
from shockdyno.run.safety import SafetyEvent
from shockdyno.run.session_state import SessionState, State, StateError
from shockdyno.run.sine_run import SineOutcome, SinePlan, SineRun
from shockdyno.samples import SampleBlock

__all__ = ["RigSession", "SineOutcome", "exit_reason"]

P = ParamSpec("P")
R = TypeVar("R")


def _stops_on_interrupt(method: Callable[P, R]) -> Callable[P, R]:
    """A signal (Ctrl-C, SIGTERM, SIGHUP) or any other exception leaving a motion (a
    recording that cannot be written) puts the stop command on the wire at once, before the
    exception unwinds through the sweep's bookkeeping (the recording, the live view) to the
    teardown, which then centres and disables. A ConfigError (a refused plan) or a
    StateError (a call the session's state refuses) comes before anything was sent:
    nothing to stop."""

    @functools.wraps(method)
    def stopping(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return method(*args, **kwargs)
        except (ConfigError, StateError):
            raise
        except BaseException:
            session = args[0]
            assert isinstance(session, RigSession)
            session._motion.halt()
            raise

    return stopping


def _console_prompt(message: str) -> None:
    input(f"{message} [Enter when done] ")


def _check_clicks(values: Mapping[str, object]) -> None:
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
            raise ConfigError(f"{name} must be a whole number >= 0, got {value!r}")


def _write_clicks(loop: ControlLoop, values: Mapping[str, int], failed: str) -> None:
    """A motorised adjuster's registers written, read back (`failed`: what a value read
    back that differs means), and watched from now on."""
    act = loop.act()
    act.write({k: int(v) for k, v in values.items()})
    got = act.read(list(values))
    if any(int(got[k]) != v for k, v in values.items()):
        raise RigFault(f"{failed}: {got}")
    loop.watch.expect({k: float(v) for k, v in values.items()})


def exit_reason(exc: BaseException | None) -> str:
    """Why a session ends, for its teardown event."""
    if exc is None:
        return "session ended"
    return signals.describe(exc) or f"{type(exc).__name__}: {exc}"


class RigSession:
    """The one place safety lives: connects the Modbus drive and the serial DAQ of a rig file,
    checks every sample against the limits, feeds the drive's watchdog from the loop that reads
    the samples, and on every way out (exception, signal, close) stops, centres and disables the
    ram. A context manager: entering connects, runs the preflight checks and enables."""

    def __init__(
        self,
        rig: RigConfig,
        *,
        prompt: Callable[[str], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
        open_daq: Callable[[DaqConfig, float], Daq] = SerialDaq,
        strokes: Sequence[Stroke] = (),
    ) -> None:
        self.rig = rig
        # Constant-velocity strokes the session will be asked for: checked against the
        # drive's acceleration_limit before enabling (preflight.check_strokes).
        self._strokes = tuple(strokes)
        self.drive_accel_m_s2: float | None = None
        self.prompt = prompt or _console_prompt
        self.clock = clock
        self._open_daq = open_daq  # any `Daq`: the session reads only what the protocol has
        self._state = SessionState()
        self._loop = ControlLoop(rig, self._state, clock)
        self._stream = self._loop.stream  # the DAQ: the session's clock and eyes
        self._log = EventLog(lambda: self._stream.t)
        self._motion = DriveMotion(rig, self._loop, self._state, self._log)
        self._nice_before: int | None = None

    # -- state and events ----------------------------------------------------------------
    @property
    def state(self) -> State:
        return self._state.state

    @property
    def enabled(self) -> bool:
        """Whether this session holds the drive enabled (enabled or moving)."""
        return self._state.armed

    @property
    def actuator(self) -> ModbusActuator | None:
        """The drive driver (None until the session is entered)."""
        return self._loop.actuator

    @property
    def daq(self) -> Daq | None:
        """The DAQ (None until the session is entered)."""
        return self._loop.daq

    @property
    def daq_time_s(self) -> float:
        """The DAQ time of the latest sample: the session's clock."""
        return self._stream.t

    @property
    def events(self) -> list[SafetyEvent]:
        """The session's safety events so far, in order."""
        return self._log.events

    def record_events(self, sink: EventSink | None) -> None:
        """Send every event so far, then each one as it happens, to `sink` (e.g. the
        recording's write_event), so that a crash cannot lose the events before it."""
        self._log.attach(sink)

    # -- enter / exit ------------------------------------------------------------------
    def __enter__(self) -> RigSession:
        if self._state.closed:
            raise StateError(f"entering the session refused: {self._state.describe()}")
        if self._loop.actuator is not None:
            raise StateError("entering the session refused: it is open already")
        self._nice_before, nice = priority.raise_priority()
        loop = self._loop
        try:
            loop.actuator = ModbusActuator(self.rig, guard=signals.hold)
            loop.actuator.connect()
            loop.daq = self._open_daq(self.rig.daq, self.rig.stroke_centre_m)
            loop.first_samples()
            limits = preflight.check_drive_limits(self.rig, loop)
            self.drive_accel_m_s2 = preflight.check_strokes(self.rig, loop, self._strokes)
            rate = preflight.check_daq_rate(self.rig, loop)
            self._log.note(
                "connect",
                f"{self.rig.actuator.describe()}, DAQ {self.rig.daq.url} ({rate}){limits}; "
                f"control loop {nice}",
            )
            self.enable()
        except BaseException as exc:
            self._teardown(f"failed to start: {exc}" if str(exc) else type(exc).__name__)
            raise
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._teardown(exit_reason(exc))

    def close(self, reason: str = "session ended") -> None:
        """Stop, centre, disable and close now (idempotent; the context exit then does nothing).

        A caller that records the session's events calls this before closing its recording,
        so that the teardown and its reason are recorded too.
        """
        self._teardown(reason)

    @_stops_on_interrupt
    def enable(self) -> None:
        """Reset faults, enable, start the heartbeat, ramp to centre (re-arms after an abort).

        The samples are read and checked before the drive is enabled: a ram beyond a
        limit (moved by hand, or by another master while the drive was off) is a trip,
        and the drive stays disabled."""
        self._state.require("enable", "enable")
        self._motion.power_on()
        self._state.to(State.ENABLED)
        self._log.note("enable", "actuator enabled, heartbeat fed by the control loop")
        # Centred when the drive says so and the DAQ's samples show it: a host that fell
        # behind reads the park long after the drive reports the centre.
        self._motion.move_to_centre(check=True, seen=True)
        # The drive says "centred" before a host that fell behind has read the samples
        # that show it (the park, the ramp): read them now, limits checked, so that the
        # session's clock is current and the next hold's backlog is its own.
        self._loop.catch_up(check=True)

    # -- adjusters and waits on a person -------------------------------------------------
    def set_clicks(self, rod_clicks: int, gas_clicks: int) -> None:
        """Set the rod adjuster and the gas bottle: written and read back on a motorised rig, or
        the drive disabled while an operator is prompted to set them."""
        _check_clicks({"rod_clicks": rod_clicks, "gas_clicks": gas_clicks})
        self._state.require("adjust", "set_clicks")
        if self.rig.adjuster == "motorised":
            failed = f"adjuster did not reach {rod_clicks}/{gas_clicks} clicks"
            _write_clicks(self._loop, {"rod_clicks": rod_clicks, "gas_clicks": gas_clicks}, failed)
            self._log.note("adjust", f"adjuster set to rod {rod_clicks}, gas {gas_clicks} clicks")
            return
        with self.parked("the operator sets the clicks"):
            self.prompt(
                f"Set the rod adjuster to {rod_clicks} clicks "
                f"and the gas bottle to {gas_clicks} clicks"
            )
        self._log.note("adjust", f"operator set rod {rod_clicks}, gas {gas_clicks} clicks")

    def set_adjusters(self, setting: Mapping[str, int], gas_clicks: int) -> None:
        """Each adjuster of a damper with several: its register `NAME_clicks` written and
        read back (motorised), or one prompt naming every adjuster (operator)."""
        values = {f"{name}_clicks": v for name, v in setting.items()} | {"gas_clicks": gas_clicks}
        _check_clicks(values)
        self._state.require("adjust", "set_adjusters")
        words = ", ".join(f"{name} {v}" for name, v in setting.items())
        if self.rig.adjuster == "motorised":
            missing = [r for r in values if r not in self.rig.registers.registers]
            if missing:
                raise ConfigError(
                    f"{self.rig.source}: a motorised adjuster needs register {missing[0]}"
                )
            _write_clicks(
                self._loop, values, f"adjusters did not reach {words}, gas {gas_clicks} clicks"
            )
            self._log.note("adjust", f"adjusters set to {words}, gas {gas_clicks} clicks")
            return
        with self.parked("the operator sets the clicks"):
            self.prompt(
                "Set "
                + ", ".join(f"the {name} adjuster to {v} clicks" for name, v in setting.items())
                + f" and the gas bottle to {gas_clicks} clicks"
            )
        self._log.note("adjust", f"operator set {words}, gas {gas_clicks} clicks")

    @contextmanager
    def parked(self, why: str) -> Iterator[None]:
        """Disable the drive for a wait on a person (or anything else the control loop
        cannot watch through), and enable it again when the wait ends normally: nothing
        feeds the watchdog meanwhile, and nothing should have to. The DAQ's backlog of the
        wait is read (unchecked: the drive was off) before enabling checks the present."""
        self._state.require("park", "parked")
        was_armed = self._state.armed
        if was_armed:
            st = self._loop.act().status()
            if st.running:
                self._motion.safe_stop(f"waiting for {why}", then=State.PARKED)
            else:
                self._motion.disable(f"waiting for {why}", then=State.PARKED)
        yield
        if was_armed:
            self._loop.catch_up(check=False)
            self.enable()

    @_stops_on_interrupt
    def read_temperature_c(self) -> float:
        """The damper's temperature (°C) at the latest sample, the DAQ's backlog read first
        (limits checked); RigFault before any temperature."""
        self._state.require("read", "read_temperature_c")
        self._loop.catch_up(check=True)
        if math.isnan(self._stream.temp):
            raise RigFault("DAQ has sent no temperature yet")
        return self._stream.temp

    # -- motions -------------------------------------------------------------------------
    @_stops_on_interrupt
    def run_sine(
        self,
        amplitude_m: float,
        frequency_hz: float,
        warmup_cycles: int,
        measured_cycles: int,
        on_block: BlockSink,
        on_actuator: ActuatorSink | None = None,
        waveform: Stroke | None = None,
    ) -> SineOutcome:
        """A sine, or with `waveform` a constant-velocity stroke (model/stroke.py) run by
        the drive's function generator at `frequency_hz` (its period's): the same ramps,
        limits, watchdog, verification and stop (sine_run.py)."""
        a, f, warmup, measured = amplitude_m, frequency_hz, warmup_cycles, measured_cycles
        if waveform is None:
            check_sine(self.rig, a, f, warmup, measured)
        else:
            check_sine(self.rig, a, f, warmup, measured, peak_velocity_m_s=waveform.velocity_m_s)
            check_stroke(self.rig, waveform, self.drive_accel_m_s2)
        with self._state.moving("run_sine"):
            plan = SinePlan(a, f, warmup, measured, waveform)
            run = SineRun(self.rig, self._loop, self._motion, self._log, plan)
            return run.run(on_block, on_actuator)

    @_stops_on_interrupt
    def hold_at(
        self, offset_m: float, velocity_m_s: float | None, dwell_s: float, on_block: BlockSink
    ) -> tuple[float, float]:
        """Move at `velocity_m_s` (None: the rig's ramp.move_velocity_m_s) to `offset_m` from
        the stroke centre (+ compression), then hold still for `dwell_s` of DAQ time; every
        sample of the move and the hold goes to `on_block`. Returns the DAQ times (arrived,
        end of the hold).

        The same limits on every sample, heartbeat and teardown as a sine: a trip makes the
        controlled stop and raises RigFault (the sweep stops, as after an aborted test).
        """
        velocity_m_s = check_hold(self.rig, offset_m, velocity_m_s, dwell_s)
        with self._state.moving("hold_at"):
            return self._motion.hold(offset_m, velocity_m_s, dwell_s, on_block)

    @_stops_on_interrupt
    def move_to(self, displacement_m: float) -> ActuatorStatus:
        """Ramp in hold mode to `displacement_m` from the stroke centre at the rig file's
        move velocity, limits watched on every sample (a trip raises `SafetyTrip`; the
        session's exit then stops, centres and disables). Refused before moving outside
        `limits.travel_m`. Returns the drive's status on arrival."""
        travel = self.rig.limits.travel_m
        if not (math.isfinite(displacement_m) and abs(displacement_m) <= travel):
            raise ConfigError(
                f"target {displacement_m * 1e3:+g} mm is outside the rig's travel of "
                f"±{travel * 1e3:g} mm ({self.rig.source} limits.travel_m); refused before moving"
            )
        with self._state.moving("move_to"):
            target = self.rig.stroke_centre_m + displacement_m
            _, st = self._motion.move(target, check=True, what="move")
        self._log.note("move", f"at {displacement_m * 1e3:+.2f} mm from centre")
        return st

    @_stops_on_interrupt
    def dwell(self, duration_s: float) -> SampleBlock:
        """Hold where the ram is for `duration_s` of DAQ time, limits and the drive watched
        as in a sine; the samples read meanwhile."""
        captured: list[SampleBlock] = []
        loop, stream = self._loop, self._stream
        with self._state.moving("dwell"):
            loop.catch_up(check=True)
            end = stream.t + duration_s
            stream.on_block = captured.append
            try:
                loop.wait(lambda s: stream.t >= end, daq_budget_s=duration_s + 2.0, what="dwell")
            finally:
                stream.on_block = None
        return SampleBlock.concat(captured) if captured else SampleBlock.empty()

    # -- teardown ------------------------------------------------------------------------
    def _teardown(self, reason: str) -> None:
        if self._state.closed:
            return
        with signals.hold():  # a signal now waits until the ram is stopped and disabled
            self._teardown_held(reason)

    def _teardown_held(self, reason: str) -> None:
        """From any state: the stop sequence if this session holds the drive enabled (the
        stop command first), else a disable; then closed, and both transports closed."""
        loop, armed = self._loop, self._state.armed
        if armed:
            self._motion.halt()  # on the wire before the exit is logged
        self._log.note("exit", reason)
        self._stream.on_block = loop.on_actuator = None
        if loop.actuator is not None and loop.daq is not None and armed:
            self._motion.safe_stop(reason)
        elif loop.actuator is not None:
            self._motion.disable(reason)
        loop.heartbeat.stop()
        self._state.to(State.CLOSED, reason)
        for closer in (loop.actuator, loop.daq):
            if closer is not None:
                try:
                    closer.close()
                except Exception as exc:  # closing must not hide the original problem
                    self._log.note("close_failed", str(exc))
        beats = loop.heartbeat
        watchdog_s = self.rig.heartbeat.timeout_s
        said = f"; {beats.describe(watchdog_s)}" if beats.beats else ""
        self._log.note("closed", f"transports closed{said}")
        priority.restore(self._nice_before)
        self._nice_before = None
