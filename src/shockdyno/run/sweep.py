"""Run a click sweep on a rig session and record every sample.

The runner knows only the RigSession contract (set clicks, read temperature, run a sine
with ramps and safety) and the recording writer; it cannot tell a simulated rig from a
real one. A safety abort or Ctrl-C ends the sweep after the current test is recorded as
aborted; everything recorded before stays on disk, and `--resume` runs what is left.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field, replace
from typing import Protocol

from shockdyno.errors import RigFault
from shockdyno.model.stroke import Stroke
from shockdyno.record.types import TestMeta
from shockdyno.rig.types import Adjuster
from shockdyno.run import signals
from shockdyno.run.gas_measure import Holder, measure_gas_force
from shockdyno.run.plan import PointKey, SweepPlan, SweepPoint
from shockdyno.run.signals import Terminated
from shockdyno.samples import SampleBlock


class _Outcome(Protocol):
    status: str
    reason: str
    measured_start_s: float | None
    measured_end_s: float | None
    dropped_frames: int
    corrupt_frames: int
    stop_sweep: bool


class Session(Holder, Adjuster, Protocol):  # Holder: hold_at, for the gas-force measurement
    """What the sweep runner needs of a rig session: set the adjusters, read the temperature,
    park the drive for a wait, hold still (the gas force), and run one test."""

    def read_temperature_c(self) -> float:
        """The damper's temperature now (°C)."""

    def parked(self, why: str) -> AbstractContextManager[None]:
        """The drive disabled for a wait on a person (or the damper's temperature)."""
        ...

    def run_sine(
        self,
        amplitude_m: float,
        frequency_hz: float,
        warmup_cycles: int,
        measured_cycles: int,
        on_block: Callable[[SampleBlock], None],
        on_actuator: Callable[[float, dict[str, float | int | bool]], None] | None = None,
        waveform: Stroke | None = None,  # a constant-velocity stroke instead of the sine
    ) -> _Outcome:
        """Run one test (a sine, or the constant-velocity `waveform`) of the given amplitude (m)
        and frequency (Hz), every sample to `on_block`; its outcome (complete, degraded,
        aborted)."""


class Writer(Protocol):
    """Where a sweep's data go (the recording, or the recording and a live viewer)."""

    def begin_test(self, meta: TestMeta) -> None:
        """Open a test (its metadata as planned)."""

    def write_samples(self, block: SampleBlock) -> None:
        """Store a block of the test's samples."""

    def write_actuator(self, t_s: float, fields: dict[str, float | int | bool | str]) -> None:
        """Store the drive's fields at DAQ time `t_s` (s)."""

    def write_event(self, t_s: float, kind: str, message: str) -> None:
        """Store a session event at DAQ time `t_s` (s)."""

    def end_test(self, meta: TestMeta) -> None:
        """Close a test with its final metadata (status, measured window)."""


class View(Protocol):
    """The operator's view of a running sweep (progress bar and live line)."""

    def start_test(self, meta: TestMeta) -> None:
        """A test begins."""

    def update(self, block: SampleBlock, dropped_frames: int = 0) -> None:
        """The test's newest samples, and the frames lost so far."""

    def end_test(self, meta: TestMeta) -> object:
        """A test ended; returns what the view summarises of it."""


@dataclass
class SweepResult:
    """The tests of a sweep by how they ended (complete, aborted, degraded), and why the sweep
    stopped ("" if it ran to the end)."""

    completed: list[TestMeta] = field(default_factory=list)
    aborted: list[TestMeta] = field(default_factory=list)
    degraded: list[TestMeta] = field(default_factory=list)  # ran, but not as planned or lossy
    stopped_reason: str = ""


def wait_for_temperature(
    session: Session,
    band_c: tuple[float, float],
    timeout_s: float,
    log: Callable[[str], None],
    sleep: Callable[[float], None] = time.sleep,
) -> float:
    """Block until the damper is inside the band; the operator cools or warms it meanwhile,
    with the drive disabled (nothing moves, and nothing needs the watchdog fed)."""
    lo, hi = band_c
    temp = session.read_temperature_c()
    if lo <= temp <= hi:
        return temp
    log(f"waiting for damper temperature {lo:g}-{hi:g} °C (now {temp:.1f} °C)")
    waited = 0.0
    with session.parked("the damper's temperature"):
        while not lo <= temp <= hi:
            if waited >= timeout_s:
                raise RigFault(
                    f"damper at {temp:.1f} °C did not reach {lo:g}-{hi:g} °C within {timeout_s:g} s"
                )
            sleep(1.0)
            waited += 1.0
            temp = session.read_temperature_c()
    return temp


def run_sweep(
    session: Session,
    plan: SweepPlan,
    writer: Writer,
    view: View,
    *,
    first_index: int = 0,
    done: set[PointKey] | None = None,
    sample_rate_hz: float,
    log: Callable[[str], None] = print,
    temperature_timeout_s: float = 1800.0,
) -> SweepResult:
    """Run `plan`'s remaining tests on `session` (points in `done` skipped; test indices from
    `first_index`), each recorded through `writer` and shown in `view`: clicks set at each
    change, the temperature band waited for, the gas force measured. A degraded test is logged
    and the sweep goes on; an aborted one (or one whose motion did not match its plan) stops it
    with RigFault after it is recorded."""
    result = SweepResult()
    index = first_index
    setting = _Setting()
    last_t = [0.0]  # DAQ time of the newest sample: events are stamped on the rig's clock
    for point in plan.remaining(done or set()):
        setting.prepare(session, plan, point, writer, log, last_t, temperature_timeout_s)
        meta = _meta(index, point, plan, sample_rate_hz, session.read_temperature_c())
        if setting.gas_force_n is not None:
            meta = replace(meta, gas_force_n=setting.gas_force_n, gas_force_source="measured")
        index += 1
        final, outcome = _run_test(session, plan, meta, writer, view, result, last_t)
        if outcome.status == "degraded" and not outcome.stop_sweep:
            log(f"test {meta.index} degraded: {outcome.reason}")
            result.degraded.append(final)
            continue
        if outcome.status != "complete":
            (result.degraded if outcome.status == "degraded" else result.aborted).append(final)
            result.stopped_reason = outcome.reason
            raise RigFault(f"test {meta.index} {outcome.status}: {outcome.reason}; sweep stopped")
        result.completed.append(final)
    return result


@dataclass
class _Setting:
    """The adjusters as the sweep last set them, and the gas force measured at them."""

    clicks: tuple[int, int, tuple[tuple[str, int], ...]] | None = None
    gas_force_n: float | None = None
    good_gas: dict[int, float] = field(default_factory=dict)  # the last usable per gas setting

    def prepare(
        self,
        session: Session,
        plan: SweepPlan,
        point: SweepPoint,
        writer: Writer,
        log: Callable[[str], None],
        last_t: list[float],
        temperature_timeout_s: float,
    ) -> None:
        """The point's clicks set (when they change), the damper in its temperature band,
        and the gas force measured at a click change."""
        clicks_changed = self.clicks != (point.clicks, point.gas_clicks, point.adjusters)
        if clicks_changed:
            if point.adjusters:
                session.set_adjusters(dict(point.adjusters), point.gas_clicks)
            else:
                session.set_clicks(point.clicks, point.gas_clicks)
            self.clicks = (point.clicks, point.gas_clicks, point.adjusters)
        if plan.temperature_band_c is not None:
            wait_for_temperature(session, plan.temperature_band_c, temperature_timeout_s, log)
        if clicks_changed and plan.measure_gas:
            # At every click change, at the tests' temperature (run/gas_measure.py says why).
            gas = measure_gas_force(session, writer.write_samples)  # samples outside any test
            writer.write_event(gas.t_s, "gas_force", gas.message())
            last_t[0] = gas.t_s
            if gas.usable:
                self.good_gas[point.gas_clicks] = round(gas.force_n, 2)
            else:
                log(f"clicks {point.clicks}: {gas.message()}")
            self.gas_force_n = self.good_gas.get(point.gas_clicks)


def _run_test(
    session: Session,
    plan: SweepPlan,
    meta: TestMeta,
    writer: Writer,
    view: View,
    result: SweepResult,
    last_t: list[float],
) -> tuple[TestMeta, _Outcome]:
    """One test recorded from its start to its end: the metadata it ends with, and how
    the session ran it. Ctrl-C or a fault mid-test: the test recorded as aborted, and the
    exception goes on."""
    begun = False

    def on_block(block: SampleBlock) -> None:
        writer.write_samples(block)
        view.update(block)
        if len(block):
            last_t[0] = float(block.t_s[-1])

    stroke = plan.stroke(meta.frequency_hz)
    # A sine is asked for as it always was (a Session without waveforms runs it).
    shape = {} if stroke is None else {"waveform": stroke}
    try:
        # A signal that lands while the test is being opened (the writer holds it until its
        # record is whole, then raises) is raised here, inside the try, once the test is begun:
        # otherwise the test would be left for the writer's close to mark without the reason.
        with signals.hold():
            writer.begin_test(meta)
            view.start_test(meta)
            begun = True
        outcome = session.run_sine(
            plan.amplitude_m,
            meta.frequency_hz,
            plan.warmup_cycles,
            plan.measured_cycles,
            on_block,
            writer.write_actuator,  # type: ignore[arg-type]
            **shape,
        )
    except BaseException as exc:  # Ctrl-C or a rig fault mid-test: keep what was recorded
        if not begun:  # the writer or the view refused the test: nothing of it to end
            raise
        final = replace(meta, status="aborted", abort_reason=_why(exc))
        writer.write_event(last_t[0], "abort", f"test {meta.index} stopped: {_why(exc)}")
        writer.end_test(final)
        view.end_test(final)
        result.aborted.append(final)
        raise
    final = replace(
        meta,
        status=outcome.status,
        measured_start_s=outcome.measured_start_s,
        measured_end_s=outcome.measured_end_s,
        dropped_frames=outcome.dropped_frames,
        corrupt_frames=outcome.corrupt_frames,
        abort_reason=outcome.reason or None,
    )
    writer.end_test(final)
    view.end_test(final)
    return final, outcome


def _meta(
    index: int, point: SweepPoint, plan: SweepPlan, sample_rate_hz: float, temp_c: float
) -> TestMeta:
    meta = _sine_meta(index, point, plan, sample_rate_hz, temp_c)
    stroke = plan.stroke(point.frequency_hz)
    if stroke is None:
        return meta
    return replace(
        meta,
        motion=stroke.waveform,
        target_velocity_m_s=stroke.velocity_m_s,
        reversal_accel_m_s2=stroke.accel_m_s2,
    )


def _sine_meta(
    index: int, point: SweepPoint, plan: SweepPlan, sample_rate_hz: float, temp_c: float
) -> TestMeta:
    return TestMeta(
        index=index,
        clicks=point.clicks,
        gas_clicks=point.gas_clicks,
        frequency_hz=point.frequency_hz,
        amplitude_m=plan.amplitude_m,
        sample_rate_hz=sample_rate_hz,
        warmup_cycles=plan.warmup_cycles,
        measured_cycles=plan.measured_cycles,
        motion="sine",
        status="running",
        start_temperature_c=round(float(temp_c), 2),
        gas_pressure_pa=plan.gas_pressure_pa,
        adjusters=dict(point.adjusters),
    )


def _why(exc: BaseException) -> str:
    if isinstance(exc, Terminated):
        return f"stopped by {signals.describe(exc)}"
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted by the operator (Ctrl-C)"
    return str(exc) or type(exc).__name__
