"""One test's motion: a sine, or a constant-velocity stroke (model/stroke.py) run by the
drive's function generator, from its setpoints (written and read back) through the start
command, the motion output's rise (t0) and the ramp-out, to its judgement by its own
samples (verify.py). A trip or a fault on the way makes the stop sequence and an
"aborted" outcome, never an exception.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from shockdyno.errors import RigFault
from shockdyno.model.stroke import Stroke
from shockdyno.rig.config import WAVEFORM_CODES, RigConfig
from shockdyno.run.control_loop import ActuatorSink, ControlLoop
from shockdyno.run.daq_stream import BlockSink
from shockdyno.run.drive_motion import DriveMotion
from shockdyno.run.events import EventLog
from shockdyno.run.safety import SafetyEvent
from shockdyno.run.verify import RunKeeper, judge_run
from shockdyno.samples import SampleBlock

SETTLE_S = 0.05  # DAQ time allowed after a profile's end for the drive to report it


@dataclass
class SineOutcome:
    """How one test ended: `complete`, `degraded` (ran, but not as planned or lossy) or
    `aborted`, why, the DAQ times (s) of its measured cycles, start and end, the frames lost and
    damaged in it, its safety events, and whether the sweep must stop."""

    status: str  # "complete" | "degraded" | "aborted"
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


@dataclass(frozen=True)
class SinePlan:
    """One test's motion: amplitude (m), frequency (Hz), warm-up and measured cycles, and a
    constant-velocity stroke instead of the sine (None: a sine)."""

    amplitude_m: float
    frequency_hz: float
    warmup_cycles: int
    measured_cycles: int
    waveform: Stroke | None = None

    def describe(self) -> str:
        """The test in words (`sine 25 mm at 1 Hz`, or the stroke's velocity and reversals)."""
        a, f, w = self.amplitude_m, self.frequency_hz, self.waveform
        if w is None:
            return f"sine {a * 1e3:g} mm at {f:g} Hz"
        accel = "" if w.accel_m_s2 is None else f", reversals at {w.accel_m_s2:g} m/s²"
        return f"{w.waveform} {a * 1e3:g} mm at {w.velocity_m_s * 1e3:g} mm/s ({f:g} Hz{accel})"

    def command(self, ramp: int) -> dict[str, float | int | bool]:
        """The actuator channel's record of what was commanded."""
        out: dict[str, float | int | bool] = {
            "cmd_amplitude_m": self.amplitude_m,
            "cmd_frequency_hz": self.frequency_hz,
            "cmd_cycles": self.warmup_cycles + self.measured_cycles,
            "cmd_ramp_cycles": ramp,
        }
        if self.waveform is not None:
            out["cmd_waveform"] = WAVEFORM_CODES[self.waveform.waveform]
            out["cmd_velocity_m_s"] = self.waveform.velocity_m_s
        return out


def waveform_setpoints(rig: RigConfig, waveform: Stroke | None) -> dict[str, float]:
    """The function generator's shape: every test writes it where the drive has the
    register (a sine after a triangle must not run a triangle)."""
    if "waveform" not in rig.registers:
        return {}
    name = "sine" if waveform is None else waveform.waveform
    out = {"waveform": float(WAVEFORM_CODES[name])}
    if waveform is not None and waveform.accel_m_s2 is not None:
        out["waveform_acceleration"] = waveform.accel_m_s2
    return out


class SineRun:
    """One test run on the drive's function generator: setpoints written and read back, the
    start, t0 from the motion bit, the ramp-out, and the verdict on its samples."""

    def __init__(
        self, rig: RigConfig, loop: ControlLoop, motion: DriveMotion, log: EventLog, plan: SinePlan
    ) -> None:
        self.rig, self.plan = rig, plan
        self._loop, self._motion, self._log = loop, motion, log
        self.ramp = rig.ramp.sine_ramp_cycles
        self.cycles = plan.warmup_cycles + plan.measured_cycles
        self.t0: float | None = None
        self.m_start: float | None = None
        self.m_end: float | None = None
        self._kept = RunKeeper()  # bounded: a day-long test keeps what its judgement needs
        self._dropped0 = self._corrupt0 = 0

    def run(self, on_block: BlockSink, on_actuator: ActuatorSink | None) -> SineOutcome:
        """Run the test, every sample to `on_block` and the commands to `on_actuator`; a RigFault
        (a trip, a lost link) becomes an aborted outcome, the controlled stop made."""
        loop = self._loop
        daq = loop.connected_daq()
        n_events = len(self._log.events)
        self._dropped0, self._corrupt0 = daq.dropped_frames, daq.corrupt_frames
        stop_sweep = False

        def sink(block: SampleBlock) -> None:
            self._kept.add(block)
            on_block(block)

        try:
            try:
                loop.catch_up(check=True)  # the backlog since the last call is not this run's
                self._dropped0, self._corrupt0 = daq.dropped_frames, daq.corrupt_frames
                loop.stream.on_block, loop.on_actuator = sink, on_actuator
                self._start()
                self._follow()
                status, reason, stop_sweep = self._verify()
            except RigFault as exc:
                status, reason = "aborted", self._motion.abort(exc).message
        finally:
            loop.stream.on_block = loop.on_actuator = None
            loop.watch.sine_running(None)
        return SineOutcome(
            status=status,
            reason=reason,
            measured_start_s=self.m_start,
            measured_end_s=self.m_end,
            dropped_frames=daq.dropped_frames - self._dropped0,
            corrupt_frames=daq.corrupt_frames - self._corrupt0,
            events=self._log.events[n_events:],
            start_s=self.t0,
            end_s=loop.stream.t,
            stop_sweep=stop_sweep,
        )

    def _start(self) -> None:
        """The profile's setpoints written and read back, its command recorded, started."""
        loop, plan = self._loop, self.plan
        act = loop.act()
        act.set_mode("sine")
        sine = {
            "sine_amplitude": plan.amplitude_m,
            "sine_frequency": plan.frequency_hz,
            "sine_centre": self.rig.stroke_centre_m,
            "sine_cycles": float(self.cycles),
            "sine_ramp_cycles": float(self.ramp),
        }
        sine.update(waveform_setpoints(self.rig, plan.waveform))
        act.write(sine)
        loop.watch.expect(sine)
        loop.watch.check_setpoints(act.read(sine), "before the start", loop.stream.t)
        loop.emit_actuator(plan.command(self.ramp))
        loop.stream.motion = False
        self._motion.stop_sent = False
        self._motion.period_s = 1.0 / plan.frequency_hz
        act.control("start")
        self._log.note("start", plan.describe())

    def _follow(self) -> None:
        """From the motion output's rise to the end of the ramp-out, the drive watched."""
        loop, f = self._loop, self.plan.frequency_hz
        total_s = (2 * self.ramp + self.cycles) / f
        t0 = self.t0 = loop.wait_motion_start(budget_s=1.0)
        self.m_start = t0 + (self.ramp + self.plan.warmup_cycles) / f
        self.m_end = self.m_start + self.plan.measured_cycles / f
        self._kept.measure((t0 + self.ramp / f, self.m_end), f)  # warm-up and measured
        end = t0 + total_s
        # Half a cycle of slack: the ramp-out ends at `end` by the drive's clock.
        loop.watch.sine_running(end - 0.5 / f, self.cycles + 2 * self.ramp)
        stream = loop.stream
        loop.wait(
            lambda s: stream.t >= end + SETTLE_S and not stream.motion and not s.running,
            daq_budget_s=total_s + 2.0,
            what="sine",
        )
        loop.act().set_mode("hold")
        self._log.note("complete", f"{self.cycles + 2 * self.ramp} cycles done")

    def _verify(self) -> tuple[str, str, bool]:
        """Judge the finished run by its own samples: (status, reason, stop the sweep)."""
        assert self.t0 is not None and self.m_end is not None
        daq = self._loop.connected_daq()
        lost = daq.dropped_frames - self._dropped0 + daq.corrupt_frames - self._corrupt0
        window = (self.t0 + self.ramp / self.plan.frequency_hz, self.m_end)
        plan = self.plan
        j = judge_run(self._kept, window, plan.amplitude_m, plan.frequency_hz, self.rig, lost)
        message = self._log.note(j.event, j.reason).message if j.event else j.reason
        return j.status, message, j.stop_sweep
