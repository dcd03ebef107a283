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
(`_pump`, heartbeat.py), never by a thread of its own: a blocked main thread leaves the
drive to stop itself. Before a wait on a person (the operator's clicks, the damper's
temperature) the drive is disabled, and enabled again after it.

Time: every wait is measured on the DAQ's clock (its sample counter), so a simulated rig
running N times faster finishes N times sooner. Only the watchdogs for a frozen DAQ or a
dead link use the host's clock, since a stalled clock cannot time itself.

The session is the state machine (connect, enable, run, hold, move, stop, teardown); its
parts live beside it: the DAQ stream (daq_stream.py: clock, limits on every sample, gaps,
a frozen stream), the heartbeat (heartbeat.py), what the drive must keep (watch.py) and
the event log (events.py).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import TracebackType
from typing import ParamSpec, TypeVar

import numpy as np

from shockdyno import priority
from shockdyno.errors import ConfigError, RigFault
from shockdyno.model.stroke import Stroke
from shockdyno.rig.actuator import ActuatorStatus, ModbusActuator
from shockdyno.rig.config import WATCHDOG_FAULT, WAVEFORM_CODES, DaqConfig, RigConfig
from shockdyno.rig.daq import READ_SIZE, SerialDaq
from shockdyno.rig.frames import FRAME_LEN, STATUS_MOTION
from shockdyno.rig.types import Daq
from shockdyno.run import signals
from shockdyno.run.daq_stream import BlockSink, DaqStream
from shockdyno.run.events import EventLog, EventSink
from shockdyno.run.heartbeat import LoopHeartbeat
from shockdyno.run.refusals import check_hold, check_sine, check_stroke
from shockdyno.run.safety import SafetyEvent, SafetyTrip
from shockdyno.run.verify import RunKeeper, judge_run
from shockdyno.run.watch import DriveWatch
from shockdyno.samples import SampleBlock

CENTRE_TOLERANCE_M = 0.001
HOLD_TOLERANCE_M = 0.0005  # a hold has arrived when the DAQ's displacement is this close
# (loose enough for a servo's steady error under the gas load; the rest itself is found
# from the samples, run/gas_measure.py)
# A command's round trip takes wall time, which a fast simulated rig turns into seconds of
# DAQ time: no DAQ-time deadline is called before this much host time has passed too.
MIN_WALL_S = 0.5
FULL_READ = READ_SIZE // FRAME_LEN - 2  # frames: a read this full means more is waiting
SETTLE_S = 0.05  # DAQ time allowed after a profile's end for the drive to report it
# The DAQ's frame rate, measured before enabling, against daq.sample_rate_hz ×
# daq.time_scale: within this factor (a wrong rate scales every velocity and ramp). It is
# measured over at least RATE_MIN_WINDOW_S and passes as soon as it agrees; a host or a
# simulated rig that stalled a moment agrees a little later, a wrong rate never does.
RATE_TOLERANCE = 1.25
RATE_MIN_WINDOW_S = 0.2
RATE_MAX_WINDOW_S = 2.0
RATE_MIN_FRAMES = 20
# The drive's own limits, read back where its register map has them: (register, the
# rig file's key, the monitor's trip attribute).
DRIVE_LIMITS = (
    ("travel_limit", "travel_m", "travel_trip_m"),
    ("velocity_limit", "velocity_m_s", "velocity_trip_m_s"),
    ("force_limit", "force_n", "force_trip_n"),
)

P = ParamSpec("P")
R = TypeVar("R")


def _stops_on_interrupt(method: Callable[P, R]) -> Callable[P, R]:
    """A signal (Ctrl-C, SIGTERM, SIGHUP) or any other exception leaving a motion (a
    recording that cannot be written) puts the stop command on the wire at once, before the
    exception unwinds through the sweep's bookkeeping (the recording, the live view) to the
    teardown, which then centres and disables. A ConfigError is a refusal before anything
    was sent: nothing to stop."""

    @functools.wraps(method)
    def stopping(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return method(*args, **kwargs)
        except ConfigError:
            raise
        except BaseException:
            session = args[0]
            assert isinstance(session, RigSession)
            session._halt()
            raise

    return stopping


class _DaqBudget:
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
        return t - self._t_start > self.seconds and self._clock() - self._wall_start > MIN_WALL_S


@dataclass
class SineOutcome:
    status: str  # "complete" | "aborted"
    reason: str
    measured_start_s: float | None  # DAQ time of the first measured cycle (None: never reached)
    measured_end_s: float | None
    dropped_frames: int
    corrupt_frames: int
    events: list[SafetyEvent] = field(default_factory=list)
    start_s: float | None = None  # DAQ time the profile started (motion output rose)
    end_s: float = math.nan  # DAQ time of the last sample of the run
    # The motion measured did not match the plan: the drive is not doing what it is told,
    # so the sweep must not go on (status is then "degraded").
    stop_sweep: bool = False


ActuatorSink = Callable[[float, dict[str, float | int | bool]], None]


def _console_prompt(message: str) -> None:
    input(f"{message} [Enter when done] ")


def _describe_start(amplitude_m: float, frequency_hz: float, waveform: Stroke | None) -> str:
    if waveform is None:
        return f"sine {amplitude_m * 1e3:g} mm at {frequency_hz:g} Hz"
    accel = "" if waveform.accel_m_s2 is None else f", reversals at {waveform.accel_m_s2:g} m/s²"
    return (
        f"{waveform.waveform} {amplitude_m * 1e3:g} mm at {waveform.velocity_m_s * 1e3:g} mm/s "
        f"({frequency_hz:g} Hz{accel})"
    )


def exit_reason(exc: BaseException | None) -> str:
    """Why a session ends, for its teardown event."""
    if exc is None:
        return "session ended"
    return signals.describe(exc) or f"{type(exc).__name__}: {exc}"


class RigSession:
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
        # drive's acceleration_limit before enabling (`_check_strokes`).
        self._strokes = tuple(strokes)
        self.drive_accel_m_s2: float | None = None
        self.prompt = prompt or _console_prompt
        self.clock = clock
        self._open_daq = open_daq  # any `Daq`: the session reads only what the protocol has
        self._log = EventLog(lambda: self._stream.t)
        self.actuator: ModbusActuator | None = None
        self.daq: Daq | None = None
        self._stream = DaqStream(rig.daq, rig.limits, clock)  # the DAQ: clock, limits, sink
        self._heartbeat = LoopHeartbeat(self._beat, rig.heartbeat.period_s, clock)
        self._armed = False
        self._stop_sent = False  # the stop command went out since the last start or enable
        # A drive ramps a profile out over its stop time or one period, the longer: the
        # last profile's period (0: none yet) sizes the stop's wait.
        self._period_s = 0.0
        self._last_status: ActuatorStatus | None = None
        self._poll_rtt = 0.0  # host time the last status poll took
        self._nice_before: int | None = None
        self._closed = False
        self._disarm_reason = ""
        self._last_poll_wall = -math.inf
        self._on_actuator: ActuatorSink | None = None
        self._watch = DriveWatch()  # setpoints and state the drive must keep (watch.py)

    # -- events ------------------------------------------------------------------------
    @property
    def events(self) -> list[SafetyEvent]:
        return self._log.events

    def record_events(self, sink: EventSink | None) -> None:
        """Send every event so far, then each one as it happens, to `sink` (e.g. the
        recording's write_event), so that a crash cannot lose the events before it."""
        self._log.attach(sink)

    def _record(self, ev: SafetyEvent) -> SafetyEvent:
        return self._log.record(ev)

    def _event(self, kind: str, message: str) -> SafetyEvent:
        return self._record(SafetyEvent(self._stream.t, kind, message))

    @property
    def enabled(self) -> bool:
        return self._armed

    @property
    def daq_time_s(self) -> float:
        """The DAQ time of the latest sample: the session's clock."""
        return self._stream.t

    # -- enter / exit ------------------------------------------------------------------
    def __enter__(self) -> RigSession:
        self._nice_before, nice = priority.raise_priority()
        try:
            self.actuator = ModbusActuator(self.rig, guard=signals.hold)
            self.actuator.connect()
            self.daq = self._open_daq(self.rig.daq, self.rig.stroke_centre_m)
            self._first_samples()
            limits = self._check_drive_limits()
            self._check_strokes()
            rate = self._check_daq_rate()
            self._event(
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
        act = self._act()
        hb = self.rig.heartbeat
        watchdog_ms = round(hb.timeout_s * 1000)
        act.write({"heartbeat_timeout_ms": watchdog_ms})
        got = int(act.read(["heartbeat_timeout_ms"])["heartbeat_timeout_ms"])
        if got == 0 or got > watchdog_ms:
            raise RigFault(
                f"drive watchdog reads {got} ms after writing {watchdog_ms} ms "
                f"({self.rig.source} heartbeat.timeout_s): refusing to enable a drive whose "
                "watchdog is off or longer than the rig file allows"
            )
        self._watch.expect({"heartbeat_timeout_ms": float(watchdog_ms)})
        act.set_mode("hold")
        before = act.status()
        if before.fault:
            self._event("reset", f"fault before enabling, reset: {before.fault_text}")
        act.control("fault_reset", enable=False)
        st = act.status()
        if st.fault:
            raise RigFault(f"actuator fault will not reset: {st.fault_text}")
        self._check_present()  # limits on samples of now, before the drive is on
        self._heartbeat.start()
        act.write({"position_command": st.position_m})  # enabling must not move the ram
        act.control(enable=True)
        self._stop_sent = False
        self._wait(lambda s: s.enabled, daq_budget_s=2.0, what="enable")
        self._armed = True
        self._event("enable", "actuator enabled, heartbeat fed by the control loop")
        # Centred when the drive says so and the DAQ's samples show it: a host that fell
        # behind reads the park long after the drive reports the centre.
        self._move_to_centre(check=True, seen=True)
        # The drive says "centred" before a host that fell behind has read the samples
        # that show it (the park, the ramp): read them now, limits checked, so that the
        # session's clock is current and the next hold's backlog is its own.
        self._catch_up(check=True)

    # -- public operations ---------------------------------------------------------------
    def set_clicks(self, rod_clicks: int, gas_clicks: int) -> None:
        for name, value in (("rod_clicks", rod_clicks), ("gas_clicks", gas_clicks)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
                raise ConfigError(f"{name} must be a whole number >= 0, got {value!r}")
        if self.rig.adjuster == "motorised":
            act = self._act()
            act.write({"rod_clicks": int(rod_clicks), "gas_clicks": int(gas_clicks)})
            got = act.read(["rod_clicks", "gas_clicks"])
            if (int(got["rod_clicks"]), int(got["gas_clicks"])) != (rod_clicks, gas_clicks):
                raise RigFault(f"adjuster did not reach {rod_clicks}/{gas_clicks} clicks: {got}")
            self._watch.expect({"rod_clicks": float(rod_clicks), "gas_clicks": float(gas_clicks)})
            self._event("adjust", f"adjuster set to rod {rod_clicks}, gas {gas_clicks} clicks")
        else:
            with self.parked("the operator sets the clicks"):
                self.prompt(
                    f"Set the rod adjuster to {rod_clicks} clicks "
                    f"and the gas bottle to {gas_clicks} clicks"
                )
            self._event("adjust", f"operator set rod {rod_clicks}, gas {gas_clicks} clicks")

    def set_adjusters(self, setting: Mapping[str, int], gas_clicks: int) -> None:
        """Each adjuster of a damper with several: its register `NAME_clicks` written and
        read back (motorised), or one prompt naming every adjuster (operator)."""
        values = {f"{name}_clicks": v for name, v in setting.items()} | {"gas_clicks": gas_clicks}
        for name, value in values.items():
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
                raise ConfigError(f"{name} must be a whole number >= 0, got {value!r}")
        words = ", ".join(f"{name} {v}" for name, v in setting.items())
        if self.rig.adjuster == "motorised":
            missing = [r for r in values if r not in self.rig.registers.registers]
            if missing:
                raise ConfigError(
                    f"{self.rig.source}: a motorised adjuster needs register {missing[0]}"
                )
            act = self._act()
            act.write({k: int(v) for k, v in values.items()})
            got = act.read(list(values))
            if any(int(got[k]) != v for k, v in values.items()):
                raise RigFault(f"adjusters did not reach {words}, gas {gas_clicks} clicks: {got}")
            self._watch.expect({k: float(v) for k, v in values.items()})
            self._event("adjust", f"adjusters set to {words}, gas {gas_clicks} clicks")
        else:
            with self.parked("the operator sets the clicks"):
                self.prompt(
                    "Set "
                    + ", ".join(f"the {name} adjuster to {v} clicks" for name, v in setting.items())
                    + f" and the gas bottle to {gas_clicks} clicks"
                )
            self._event("adjust", f"operator set {words}, gas {gas_clicks} clicks")

    @contextmanager
    def parked(self, why: str) -> Iterator[None]:
        """Disable the drive for a wait on a person (or anything else the control loop
        cannot watch through), and enable it again when the wait ends normally: nothing
        feeds the watchdog meanwhile, and nothing should have to. The DAQ's backlog of the
        wait is read (unchecked: the drive was off) before enabling checks the present."""
        was_armed = self._armed
        if was_armed:
            st = self._act().status()
            if st.running:
                self._safe_stop(f"waiting for {why}")
            else:
                self._disable(f"waiting for {why}")
        yield
        if was_armed:
            self._catch_up(check=False)
            self.enable()

    @_stops_on_interrupt
    def read_temperature_c(self) -> float:
        self._catch_up(check=True)
        if math.isnan(self._stream.temp):
            raise RigFault("DAQ has sent no temperature yet")
        return self._stream.temp

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
        limits, watchdog, verification and stop."""
        self._check_sine(amplitude_m, frequency_hz, warmup_cycles, measured_cycles, waveform)
        if not self._armed:
            raise RigFault(f"actuator is not enabled (disarmed by: {self._disarm_reason})")
        daq = self._daq()
        act = self._act()
        n_events = len(self.events)
        stop_sweep = False
        dropped0, corrupt0 = daq.dropped_frames, daq.corrupt_frames
        ramp = self.rig.ramp.sine_ramp_cycles
        cycles = warmup_cycles + measured_cycles
        total_s = (2 * ramp + cycles) / frequency_hz
        t0: float | None = None
        m_start: float | None = None
        m_end: float | None = None
        captured = RunKeeper()  # bounded: a day-long test keeps what its judgement needs

        def sink(block: SampleBlock) -> None:
            captured.add(block)
            on_block(block)

        try:
            try:
                self._catch_up(check=True)  # the backlog since the last call is not this run's
                dropped0, corrupt0 = daq.dropped_frames, daq.corrupt_frames
                self._stream.on_block, self._on_actuator = sink, on_actuator
                act.set_mode("sine")
                sine = {
                    "sine_amplitude": amplitude_m,
                    "sine_frequency": frequency_hz,
                    "sine_centre": self.rig.stroke_centre_m,
                    "sine_cycles": float(cycles),
                    "sine_ramp_cycles": float(ramp),
                }
                sine.update(self._waveform_setpoints(waveform))
                act.write(sine)
                self._watch.expect(sine)
                self._watch.check_setpoints(act.read(sine), "before the start", self._stream.t)
                command: dict[str, float | int | bool] = {
                    "cmd_amplitude_m": amplitude_m,
                    "cmd_frequency_hz": frequency_hz,
                    "cmd_cycles": cycles,
                    "cmd_ramp_cycles": ramp,
                }
                if waveform is not None:
                    command["cmd_waveform"] = WAVEFORM_CODES[waveform.waveform]
                    command["cmd_velocity_m_s"] = waveform.velocity_m_s
                self._emit_actuator(command)
                self._stream.motion = False
                self._stop_sent = False
                self._period_s = 1.0 / frequency_hz
                act.control("start")
                self._event("start", _describe_start(amplitude_m, frequency_hz, waveform))
                t0 = self._wait_motion_start(budget_s=1.0)
                m_start = t0 + (ramp + warmup_cycles) / frequency_hz
                m_end = m_start + measured_cycles / frequency_hz
                full_amplitude = t0 + ramp / frequency_hz  # warm-up and measured cycles
                captured.measure((full_amplitude, m_end), frequency_hz)
                end = t0 + total_s
                # Half a cycle of slack: the ramp-out ends at `end` by the drive's clock.
                self._watch.sine_running(end - 0.5 / frequency_hz, cycles + 2 * ramp)
                self._wait(
                    lambda s: (
                        self._stream.t >= end + SETTLE_S
                        and not self._stream.motion
                        and not s.running
                    ),
                    daq_budget_s=total_s + 2.0,
                    what="sine",
                )
                act.set_mode("hold")
                reason = f"{cycles + 2 * ramp} cycles done"
                status = "complete"
                self._event("complete", reason)
                status, reason, stop_sweep = self._verify(
                    captured, full_amplitude, m_end, amplitude_m, frequency_hz, dropped0, corrupt0
                )
            except RigFault as exc:
                self._halt()  # the stop on the wire first, the bookkeeping after
                ev = exc.event if isinstance(exc, SafetyTrip) else self._event("fault", str(exc))
                if isinstance(exc, SafetyTrip):
                    self._record(ev)
                status, reason = "aborted", ev.message
                self._safe_stop(ev.message)
        finally:
            self._stream.on_block = self._on_actuator = None
            self._watch.sine_running(None)
        return SineOutcome(
            status=status,
            reason=reason,
            measured_start_s=m_start,
            measured_end_s=m_end,
            dropped_frames=daq.dropped_frames - dropped0,
            corrupt_frames=daq.corrupt_frames - corrupt0,
            events=self.events[n_events:],
            start_s=t0,
            end_s=self._stream.t,
            stop_sweep=stop_sweep,
        )

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
        if not self._armed:
            raise RigFault(f"actuator is not enabled (disarmed by: {self._disarm_reason})")
        self._act()  # not connected: refused here, before the stop a failed move makes
        target = self.rig.stroke_centre_m + offset_m
        try:
            # Unlike a sine's, the backlog goes to on_block: consecutive holds (the gas-force
            # measurement's) then stream every sample between them too.
            self._stream.on_block = on_block
            self._catch_up(check=True)
            # Arrived when the drive says so and the DAQ's samples show it: at a fast
            # simulated rig's speed the stream lags the drive by a good part of a second.
            self._move(
                target,
                check=True,
                what=f"move to {offset_m * 1e3:+g} mm",
                velocity_m_s=velocity_m_s,
                settled=lambda: abs(self._stream.x - offset_m) < HOLD_TOLERANCE_M,
            )
            arrived = self._stream.t
            self._wait(lambda s: self._stream.t >= arrived + dwell_s, daq_budget_s=dwell_s + 2.0,
                       what="hold")  # fmt: skip
            return arrived, self._stream.t
        except (RigFault, SafetyTrip) as exc:
            self._halt()
            ev = exc.event if isinstance(exc, SafetyTrip) else self._event("fault", str(exc))
            if isinstance(exc, SafetyTrip):
                self._record(ev)
            self._safe_stop(ev.message)
            raise RigFault(ev.message) from None
        finally:
            self._stream.on_block = None

    def _verify(
        self,
        run: RunKeeper,
        m_start: float,
        m_end: float,
        amplitude_m: float,
        frequency_hz: float,
        dropped0: int,
        corrupt0: int,
    ) -> tuple[str, str, bool]:
        """Judge a finished run by its own samples: (status, reason, stop the sweep)."""
        daq = self._daq()
        lost = daq.dropped_frames - dropped0 + daq.corrupt_frames - corrupt0
        j = judge_run(run, (m_start, m_end), amplitude_m, frequency_hz, self.rig, lost)
        message = self._event(j.event, j.reason).message if j.event else j.reason
        return j.status, message, j.stop_sweep

    def _check_sine(
        self, a: float, f: float, warmup: int, measured: int, waveform: Stroke | None = None
    ) -> None:
        if waveform is None:
            check_sine(self.rig, a, f, warmup, measured)
            return
        check_sine(self.rig, a, f, warmup, measured, peak_velocity_m_s=waveform.velocity_m_s)
        check_stroke(self.rig, waveform, self.drive_accel_m_s2)

    def _waveform_setpoints(self, waveform: Stroke | None) -> dict[str, float]:
        """The function generator's shape: every test writes it where the drive has the
        register (a sine after a triangle must not run a triangle)."""
        regs = self.rig.registers
        if "waveform" not in regs:
            return {}
        name = "sine" if waveform is None else waveform.waveform
        out = {"waveform": float(WAVEFORM_CODES[name])}
        if waveform is not None and waveform.accel_m_s2 is not None:
            out["waveform_acceleration"] = waveform.accel_m_s2
        return out

    # -- plumbing ------------------------------------------------------------------------
    def _act(self) -> ModbusActuator:
        if self.actuator is None or self._closed:
            raise RigFault("rig session is not open")
        return self.actuator

    def _daq(self) -> Daq:
        if self.daq is None or self._closed:
            raise RigFault("rig session is not open")
        return self.daq

    def _first_samples(self) -> None:
        """Wait (host clock: the DAQ clock is not yet known) for the first valid frames."""
        start = self.clock()
        while self.clock() - start < max(2.0, 4 * self.rig.daq.frozen_timeout_s):
            if len(self._pump(check=False)):
                return
        raise RigFault(f"DAQ {self.rig.daq.url}: no valid frames")

    def _pump(self, check: bool) -> SampleBlock:
        """Read the DAQ once (daq_stream.py: the limits on every sample), then feed the
        drive's watchdog: only a loop that reads and checks keeps the drive alive. A beat
        that fails is a lost link (stopping, the stop's own requests will say so)."""
        block = self._stream.read(self._daq, check)
        try:
            self._heartbeat.feed()
        except RigFault as exc:
            if check:
                raise SafetyTrip(
                    SafetyEvent(self._stream.t, "link_lost", f"lost link to actuator: {exc}")
                ) from None
        return block

    def _beat(self) -> None:
        self._act().beat()

    def _check_present(self) -> None:
        """Read (limits checked) until a read brings samples and the backlog is gone: an
        empty read (none arrived in its few ms) would otherwise end a catch-up that checked
        nothing (a ram another master moved beyond the travel limit was enabled again)."""
        while not len(self._pump(check=True)):
            pass  # a DAQ that stays silent trips daq_frozen after daq.frozen_timeout_s
        self._catch_up(check=True)

    def _catch_up(self, check: bool) -> None:
        """Read until the DAQ backlog is gone (e.g. after an operator prompt)."""
        for _ in range(10000):
            if len(self._pump(check)) < FULL_READ:
                return

    def _poll(self, check: bool, force: bool = False) -> ActuatorStatus | None:
        now = self.clock()
        if not force and now - self._last_poll_wall < self.rig.poll_period_s:
            return None
        self._last_poll_wall = now
        try:
            st = self._act().status(self._watch.setpoints)
        except RigFault as exc:
            if check:
                raise SafetyTrip(SafetyEvent(self._stream.t, "link_lost", str(exc))) from None
            raise
        self._poll_rtt = self.clock() - now
        self._last_status = st
        self._emit_actuator(st.fields())
        if check:
            self._watch.check_setpoints(st.setpoints, "at a status poll", self._stream.t)
            self._watch.check_state(st, self._stream.t, self._armed, self._stream.fresh)
        if check and st.fault:
            raise SafetyTrip(
                SafetyEvent(self._stream.t, "actuator_fault", f"actuator fault: {st.fault_text}")
            )
        return st

    def _emit_actuator(self, fields: dict[str, float | int | bool]) -> None:
        if self._on_actuator is not None:
            self._on_actuator(self._stream.t, fields)

    def _wait(
        self,
        done: Callable[[ActuatorStatus], bool],
        *,
        daq_budget_s: float,
        what: str,
        check: bool = True,
    ) -> ActuatorStatus:
        """Pump and poll until done(status); budget on the DAQ clock (`_DaqBudget`), guard
        on the host's."""
        self._catch_up(check)
        budget = _DaqBudget(daq_budget_s, self.clock)
        budget.read(0, self._stream.t)  # the catch-up ended on a short read
        wall_start = self.clock()
        wall_guard = daq_budget_s * 2 + 5.0
        while True:
            budget.read(len(self._pump(check)), self._stream.t)
            st = self._poll(check)
            if st is not None and done(st):
                return st
            if budget.spent(self._stream.t):
                # Judge by a status read taken after the deadline, not one from before it
                # (at high sim speeds one poll period spans seconds of DAQ time).
                st = self._poll(check, force=True)
                if st is not None and done(st):
                    return st
                raise RigFault(f"{what}: not done within {daq_budget_s:.3g} s of DAQ time")
            if self.clock() - wall_start > wall_guard:
                raise RigFault(f"{what}: not done within {wall_guard:.3g} s")

    def _wait_motion_start(self, budget_s: float) -> float:
        """DAQ time of the first sample with the drive's motion output set.

        The budget is `_wait`'s (`_DaqBudget`); the backlog before it is searched for the
        start all the same."""
        budget = _DaqBudget(budget_s, self.clock)
        wall_start = self.clock()
        prev = False
        while True:
            block = self._pump(check=True)
            if len(block):
                bits = (block.status & STATUS_MOTION) != 0
                before = np.concatenate(([prev], bits[:-1]))
                rising = np.flatnonzero(bits & ~before)
                if rising.size:
                    return float(block.t_s[rising[0]])
                prev = bool(bits[-1])
            budget.read(len(block), self._stream.t)
            self._poll(check=True)
            waited = self.clock() - wall_start
            if budget.spent(self._stream.t) or waited > 2 * budget_s + 5:
                raise RigFault(
                    f"the drive did not start the sine (no motion output within {budget_s:g} s of "
                    f"DAQ time, {waited:.1f} s of host time)"
                )

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
        if not self._armed:
            raise RigFault(f"actuator is not enabled (disarmed by: {self._disarm_reason})")
        _, st = self._move(self.rig.stroke_centre_m + displacement_m, check=True, what="move")
        self._event("move", f"at {displacement_m * 1e3:+.2f} mm from centre")
        return st

    @_stops_on_interrupt
    def dwell(self, duration_s: float) -> SampleBlock:
        """Hold where the ram is for `duration_s` of DAQ time, limits and the drive watched
        as in a sine; the samples read meanwhile."""
        captured: list[SampleBlock] = []
        self._catch_up(check=True)
        end = self._stream.t + duration_s
        self._stream.on_block = captured.append
        try:
            self._wait(lambda s: self._stream.t >= end, daq_budget_s=duration_s + 2.0, what="dwell")
        finally:
            self._stream.on_block = None
        return SampleBlock.concat(captured) if captured else SampleBlock.empty()

    def _move_to_centre(self, check: bool, seen: bool = False) -> None:
        """`seen`: also wait for the DAQ's samples to show the ram centred (not in a stop,
        where the DAQ may be what failed)."""
        settled = (lambda: abs(self._stream.x) < CENTRE_TOLERANCE_M) if seen else (lambda: True)
        distance, _ = self._move(
            self.rig.stroke_centre_m, check=check, what="ramp to centre", settled=settled
        )
        self._event("centre", f"at stroke centre ({distance * 1e3:.1f} mm ramp)")

    def _move(
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
        act = self._act()
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
        arrived = self._wait(
            lambda s: (
                s.target_reached and abs(s.position_m - target_m) < CENTRE_TOLERANCE_M and settled()
            ),
            daq_budget_s=distance / v + 2.0,
            what=what,
            check=check,
        )
        return distance, arrived

    def _halt(self) -> bool:
        """Put the controlled-stop command on the wire now, without waiting for anything
        (no event, no status read when a poll is fresh): the first request of every stop.
        Whether the stop has been sent (now or since the last start)."""
        act = self.actuator
        if act is None or self._closed:
            return False
        if self._stop_sent:
            return True
        st = self._last_status
        # Fresh: about one poll old (on RTU a poll takes ~0.1 s: a read before the stop
        # would double the time to the stop)
        age = self.clock() - self._last_poll_wall
        fresh = st is not None and age < 4 * self.rig.poll_period_s + 2 * self._poll_rtt
        try:
            # A drive someone else disabled stays disabled: the stop goes without the
            # enable bit, which would otherwise re-enable it.
            enabled = st.enabled if fresh and st is not None else act.status().enabled
            act.control("stop", enable=enabled)
        except RigFault:
            return False  # the stop sequence's own stop step tries again, and says why
        self._stop_sent = True
        return True

    def _safe_stop(self, reason: str) -> None:
        """Controlled stop, ramp to centre, disable. Every step is tried; none may raise."""
        sent = self._halt()
        self._event("stop", f"controlled stop: {reason}")
        steps: list[tuple[str, Callable[[], None]]] = [
            ("watchdog", self._restore_watchdog),
            ("stop", self._wait_stopped if sent else self._stop_motion),
            ("reset", self._reset_fault),
            ("centre", lambda: self._move_to_centre(check=False)),
        ]
        for name, step in steps:
            try:
                step()
            except RigFault as exc:
                self._event("stop_step_failed", f"{name}: {exc}")
                if name == "stop":
                    break  # a drive that will not stop must not be asked to move
        self._disable(reason)

    def _restore_watchdog(self) -> None:
        """If another master lengthened the watchdog, a host that dies mid-stop must still
        leave the drive to stop itself in the rig file's time."""
        self._act().write({"heartbeat_timeout_ms": round(self.rig.heartbeat.timeout_s * 1000)})

    def _stop_motion(self) -> None:
        act = self._act()
        # A drive someone else disabled stays disabled: the stop goes without the enable
        # bit, which would otherwise re-enable it.
        act.control("stop", enable=act.status().enabled)
        self._stop_sent = True
        self._wait_stopped()

    def _wait_stopped(self) -> None:
        self._wait(
            lambda s: not s.running,
            daq_budget_s=max(self.rig.ramp.stop_time_s, self._period_s) + 2.0,
            what="controlled stop",
            check=False,
        )

    def _reset_fault(self) -> None:
        act = self._act()
        st = act.status()
        if not st.fault:
            return
        if st.fault_text == WATCHDOG_FAULT and st.enabled:
            # Its watchdog's fault reaction ends in a disable: a reset before it would
            # be overtaken by it (the ram cut off mid-ramp on the way to the centre).
            self._wait(lambda s: not s.enabled, daq_budget_s=2.0, what="watchdog stop", check=False)
        self._event("reset", f"fault reset: {st.fault_text}")
        act.control("fault_reset")
        after = act.status()
        if after.fault:
            raise RigFault(f"fault will not reset: {after.fault_text}")

    def _disable(self, reason: str) -> None:
        self._armed = False
        self._disarm_reason = reason
        try:
            self._act().control(enable=False)
            self._event("disable", "actuator disabled")
        except RigFault as exc:
            self._event("stop_step_failed", f"disable: {exc}")
        self._heartbeat.stop()

    # -- checks before enabling ------------------------------------------------------------
    def _check_drive_limits(self) -> str:
        """The rig file's trips (limits with their margin) within the drive's own limits,
        where its register map has them: a drive that stops first ends a test with a fault
        instead of the session's controlled stop, and a limit the drive cannot reach is a
        rig file that describes another machine."""
        names = [reg for reg, _, _ in DRIVE_LIMITS if reg in self.rig.registers]
        if not names:
            return ""
        got = self._act().read(names)
        for reg, key, trip_attr in DRIVE_LIMITS:
            if reg not in got:
                continue
            trip = float(getattr(self._stream.monitor, trip_attr))
            if not got[reg] > 0 or trip > got[reg] * (1 + 1e-6):
                raise ConfigError(
                    f"{self.rig.source} limits.{key}: the session trips at {trip:g} (with "
                    f"limits.trip_margin), beyond the drive's own {reg} of {got[reg]:g}; "
                    "lower the limit (refused before enabling)"
                )
        return "; the drive's own " + ", ".join(f"{reg} {got[reg]:g}" for reg in names)

    def _check_strokes(self) -> None:
        """The drive's acceleration_limit read (where its map has it) and every planned
        constant-velocity stroke checked against it and the rig file, before enabling."""
        if "acceleration_limit" in self.rig.registers:
            got = self._act().read(["acceleration_limit"])["acceleration_limit"]
            self.drive_accel_m_s2 = float(got)
        for stroke in self._strokes:
            check_stroke(self.rig, stroke, self.drive_accel_m_s2)

    def _check_daq_rate(self) -> str:
        """The frames per host second against daq.sample_rate_hz × daq.time_scale, before
        the drive is enabled: a DAQ at 1 kHz described as 50 Hz reads velocities 20x low,
        and every limit and ramp timed on its clock is wrong.

        Measured over consecutive windows of RATE_MIN_WINDOW_S (and RATE_MIN_FRAMES); the
        first window that agrees passes. A stream that stalled a moment and catches up (a
        busy host, a simulated rig starting) agrees in a later window; a wrong rate in
        none, and after RATE_MAX_WINDOW_S it is refused. A simulated rig at another speed
        than real time (time_scale != 1) may fall behind for good (a slow plant), so only
        a faster DAQ than stated is refused for it."""
        cfg = self.rig.daq
        expected = cfg.frames_per_host_s
        self._catch_up(check=False)
        start = self.clock()
        seq0, wall0 = self._stream.seq, start
        seen: list[float] = []
        while seq0 is not None:
            self._catch_up(check=False)
            now = self.clock()
            frames = (self._stream.seq or seq0) - seq0
            last = now - start >= RATE_MAX_WINDOW_S
            if (now - wall0 >= RATE_MIN_WINDOW_S and frames >= RATE_MIN_FRAMES) or last:
                measured = frames / max(now - wall0, 1e-9)
                seen.append(measured)
                slow = measured * RATE_TOLERANCE < expected and cfg.time_scale == 1.0
                if not slow and measured <= expected * RATE_TOLERANCE:
                    return f"{measured:.0f} frames/s"
                if last:
                    break
                seq0, wall0 = self._stream.seq, now
        got = f"{min(seen):.0f}-{max(seen):.0f}" if seen else "no"
        raise ConfigError(
            f"DAQ {cfg.url} delivers {got} frames/s, the rig file says {expected:g} "
            f"({self.rig.source} daq.sample_rate_hz {cfg.sample_rate_hz:g}"
            f"{cfg.time_scale_note}): a wrong "
            "rate scales every velocity and time; refused before enabling"
        )

    # -- teardown ------------------------------------------------------------------------
    def _teardown(self, reason: str) -> None:
        if self._closed:
            return
        with signals.hold():  # a signal now waits until the ram is stopped and disabled
            self._teardown_held(reason)

    def _teardown_held(self, reason: str) -> None:
        if self._armed:
            self._halt()  # on the wire before the exit is logged
        self._event("exit", reason)
        self._stream.on_block = self._on_actuator = None
        if self.actuator is not None and self.daq is not None and self._armed:
            self._safe_stop(reason)
        elif self.actuator is not None:
            self._disable(reason)
        self._heartbeat.stop()
        self._closed = True
        for closer in (self.actuator, self.daq):
            if closer is not None:
                try:
                    closer.close()
                except Exception as exc:  # closing must not hide the original problem
                    self._record(SafetyEvent(self._stream.t, "close_failed", str(exc)))
        beats = self._heartbeat
        loop = f"; {beats.describe(self.rig.heartbeat.timeout_s)}" if beats.beats else ""
        self._event("closed", f"transports closed{loop}")
        priority.restore(self._nice_before)
        self._nice_before = None
