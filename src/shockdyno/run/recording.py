"""Run a sweep plan on a rig into a recording: resume checks, refusals before the rig
is touched, the live view, the session and the writer, and a teardown that is recorded.

The commands (`sweep`, `demo`) call `record_sweep`; it holds no argument parsing.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

from rich.console import Console

from shockdyno.errors import ConfigError, RecordingError
from shockdyno.outputs import check_recording_output
from shockdyno.record import open_recording
from shockdyno.record.lock import recording_lock
from shockdyno.record.queued import QueuedWriter
from shockdyno.record.writer import RecordingWriter
from shockdyno.run.plan import LONG_SWEEP_S, PointKey, SweepPlan, SweepPoint, duration_text
from shockdyno.run.refusals import check_band, check_sine
from shockdyno.units import SI, Units

NEW_SUFFIX = ".new.mcap"  # a forced sweep's recording, until its first test completes

if TYPE_CHECKING:
    from shockdyno.record.types import TestMeta
    from shockdyno.rig.config import RigConfig
    from shockdyno.run.sweep import SweepResult, Writer


def record_sweep(
    rig: RigConfig,
    plan: SweepPlan,
    output: Path,
    *,
    metadata: dict[str, str],
    overwrite: bool = False,
    resume: bool = False,
    console: Console | None = None,
    units: Units = SI,
    live: Writer | None = None,
) -> SweepResult | None:
    """Run the plan on the rig into the recording; returns the SweepResult (None when the
    recording being resumed had nothing left to run). The recording
    has one writer: a second sweep, resume or --force on it, under any name (a link), is
    refused (record/lock.py). `live` (a viewer, `sweep --live`) gets every call the
    recording gets, after it."""
    if output.exists() and not output.is_file():
        check_recording_output(output, force=True)  # a folder, a FIFO, a device: refused
    with recording_lock(output):
        if not resume:
            check_recording_output(output, force=overwrite)
        options = (overwrite, resume, units, live)
        return _record_sweep(rig, plan, output, metadata, console or Console(), options)


def _record_sweep(
    rig: RigConfig,
    plan: SweepPlan,
    output: Path,
    metadata: dict[str, str],
    console: Console,
    options: tuple[bool, bool, Units, Writer | None],
) -> SweepResult | None:
    """`record_sweep` once the recording is locked (`options`: its overwrite, resume,
    units and live)."""
    overwrite, resume, units, live = options
    # here: the rig session and the live view add 28 and 7 ms to every command's start
    from shockdyno.run.fanout import Fanout
    from shockdyno.run.liveview import LiveView
    from shockdyno.run.session import RigSession, exit_reason
    from shockdyno.run.sweep import run_sweep

    ident = identity(rig, plan)
    if resume:
        done, first_index = _resumed(output, plan, metadata, ident, console)
    elif output.exists() and not overwrite:
        raise RecordingError(f"{output} exists: use --force to overwrite or --resume to continue")
    else:
        done, first_index = set(), 0
    todo = plan.remaining(done)
    if not todo:
        console.print("nothing left to run")
        return None
    _refuse_before_the_rig(rig, plan)
    _say_if_long(rig, plan, todo, console)
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecordingError(
            f"-o {output}: cannot create {output.parent} ({exc.strerror})"
        ) from None
    view = LiveView(len(todo), console=console, units=units)
    LiveView.warm_up()  # nothing the loop calls may take its first long time with the drive on

    def prompt(message: str) -> None:
        with view.paused():  # hold the live display while the operator reads and answers
            console.input(f"[bold yellow]{message}[/] - press Enter when done ")

    writer = _open_writer(rig, output, metadata, ident, overwrite=overwrite, resume=resume)
    sink: Writer = writer if live is None else Fanout(writer, live)
    started = False
    try:
        # The recording is open and writable before the rig is enabled; a rig that does not
        # answer (or refuses to start) leaves no empty recording behind.
        with view, RigSession(rig, prompt=prompt, strokes=plan.strokes) as session:
            started = True
            session.record_events(sink.write_event)
            try:
                return run_sweep(
                    session,
                    plan,
                    sink,
                    view,
                    first_index=first_index,
                    done=done,
                    sample_rate_hz=rig.sample_rate_hz,
                    log=console.print,
                )
            finally:
                # Tear down before the recording closes, so the stop and its reason are in it.
                session.close(exit_reason(sys.exc_info()[1]))
                session.record_events(None)
    finally:
        _close_writer(writer, started, output, console)


def _resumed(
    output: Path,
    plan: SweepPlan,
    metadata: dict[str, str],
    ident: dict[str, str],
    console: Console,
) -> tuple[set[PointKey], int]:
    """A recording to resume, checked to be this plan's, this set's and this rig's: the
    points it completed and the next test's index."""
    if not output.is_file():
        raise RecordingError(f"nothing to resume: {output} does not exist")
    previous = open_recording(output).require_recording()
    _check_resume_matches(previous.tests, plan, output)
    _check_same_set(previous.metadata, metadata, output)
    _check_same_identity(previous.identity, ident, output)
    done = previous.completed_points()
    console.print(f"resuming {output}: {len(done)} tests done, {len(plan.remaining(done))} to go")
    return done, len(previous.tests)


def _refuse_before_the_rig(rig: RigConfig, plan: SweepPlan) -> None:
    """Everything that can be refused, refused before the rig is touched."""
    for frequency in plan.frequencies_hz:
        stroke = plan.stroke(frequency)
        check_sine(rig, plan.amplitude_m, frequency, plan.warmup_cycles, plan.measured_cycles,
                   None if stroke is None else stroke.velocity_m_s)  # fmt: skip
    if plan.temperature_band_c is not None:
        check_band(rig, plan.temperature_band_c)
    if plan.adjust and rig.adjuster == "motorised":
        for name, _ in plan.adjust:
            if f"{name}_clicks" not in rig.registers.registers:
                raise ConfigError(
                    f"{rig.source}: the {name} adjuster is motorised (rig.adjuster) but the "
                    f"register map has no {name}_clicks; add it, or set rig.adjuster = "
                    '"operator"'
                )
    if rig.adjuster == "operator" and not sys.stdin.isatty():
        raise ConfigError(
            f"{rig.source}: the adjuster is set by an operator, who confirms each setting at a "
            "terminal; run the sweep from a terminal (stdin is not one)"
        )


def _open_writer(
    rig: RigConfig,
    output: Path,
    metadata: dict[str, str],
    ident: dict[str, str],
    *,
    overwrite: bool,
    resume: bool,
) -> QueuedWriter:
    """The sweep's writer, in a thread of its own (record/queued.py). A recording that
    replaces one (--force) is written beside it and takes its place when its first test
    completes (record/writer.py)."""

    target, replaces = output, None
    if not resume and output.exists():
        target = output.with_name(f"{output.name.removesuffix('.mcap')}{NEW_SUFFIX}")
        replaces = output
        if target.exists() or target.is_symlink():  # the leftover of an earlier forced run
            check_recording_output(target, force=True)
            target.unlink()
    return QueuedWriter(
        RecordingWriter(
            target,
            metadata=metadata,
            rig_toml=rig.raw_toml,
            resume=resume,
            replaces=replaces,
            identity=ident,
        )
    )


def _close_writer(writer: QueuedWriter, started: bool, output: Path, console: Console) -> None:
    """Close the recording; say where this run's recording is when it did not replace the
    old one. A close that fails while another error is on its way does not hide it."""
    failing = sys.exc_info()[0] is not None
    inner = writer.writer
    try:
        if not started or (inner.replaces is not None and inner.tests_begun == 0):
            writer.discard()
        else:
            writer.close()
    except RecordingError:
        if not failing:
            raise
    if inner.replaces is not None and inner.tests_begun:
        console.print(
            f"the first test did not complete: {output} is kept as it was; this run's "
            f"recording is {inner.path}",
            soft_wrap=True,
        )


def identity(rig: RigConfig, plan: SweepPlan) -> dict[str, str]:
    """What a recording set is a measurement of, besides its damper and operator: the rig
    (its limits, calibration and rate, not where it is reached) and the plan. A resumed
    sweep must match it (item 46.8)."""
    d = rig.daq
    rig_doc = {
        "name": rig.name,
        "stroke_centre_m": rig.stroke_centre_m,
        "limits": asdict(rig.limits),
        "sample_rate_hz": d.sample_rate_hz,
        "calibration": asdict(d.calibration),
    }
    plan_doc = {
        "clicks": list(plan.clicks),
        "gas_clicks": plan.gas_clicks,
        "frequencies_hz": list(plan.frequencies_hz),
        "amplitude_m": plan.amplitude_m,
        "warmup_cycles": plan.warmup_cycles,
        "measured_cycles": plan.measured_cycles,
        "gas_pressure_pa": plan.gas_pressure_pa,
    }
    if plan.strokes:  # a sine plan's identity as it always was
        plan_doc["waveform"] = plan.waveform
        plan_doc["velocities_m_s"] = [s.velocity_m_s for s in plan.strokes]
        plan_doc["reversal_accel_m_s2"] = [s.accel_m_s2 for s in plan.strokes]
    if plan.adjust:  # only a sweep over several adjusters says so (the one rod's as before)
        plan_doc |= {"adjust": {n: list(v) for n, v in plan.adjust}, "design": plan.design}
        if plan.held:
            plan_doc["base"] = dict(plan.held)
    return {
        "rig_identity": json.dumps(rig_doc, sort_keys=True),
        "plan": json.dumps(plan_doc, sort_keys=True),
    }


def _check_resume_matches(tests: list[TestMeta], plan: SweepPlan, output: Path) -> None:
    """A resumed sweep must measure like the one it continues, or the set mixes two tests."""
    for meta in tests:
        same = (
            math.isclose(meta.amplitude_m, plan.amplitude_m, rel_tol=1e-6)
            and meta.warmup_cycles == plan.warmup_cycles
            and meta.measured_cycles == plan.measured_cycles
        )
        if not same:
            raise ConfigError(
                f"{output} was recorded at {meta.amplitude_m * 1e3:g} mm, "
                f"{meta.warmup_cycles} warm-up and {meta.measured_cycles} measured cycles; "
                "--resume must use the same --amplitude-mm, --warmup-cycles and --cycles"
            )


def _check_same_set(before: dict[str, str], now: dict[str, str], output: Path) -> None:
    """One recording set holds one damper, measured by one operator, on one rig set-up
    (another rig file, its limits or calibration), to one plan (another gas pressure, other
    frequencies or clicks): a resumed part must be all of that."""
    for key, flag in (("damper_id", "--damper-id"), ("operator", "--operator")):
        if before.get(key, "") != now.get(key, ""):
            raise ConfigError(
                f"{output} was recorded with {key} {before.get(key, '')!r}; resuming with "
                f"{flag} {now.get(key, '')!r} would mix two in one set (give the same {flag})"
            )
    if before.get("rig", now.get("rig")) != now.get("rig"):
        raise ConfigError(
            f"{output} was recorded on rig {before.get('rig')!r}; resuming on "
            f"{now.get('rig')!r} would mix two rigs in one set"
        )


def _check_same_identity(before: dict[str, str], now: dict[str, str], output: Path) -> None:
    """The rig set-up and plan the set was recorded with (record/schemas.py
    IDENTITY_METADATA_NAME), where it kept them."""
    for key, what in (("rig_identity", "rig set-up"), ("plan", "plan")):
        if key not in before:
            continue  # recorded before this was stored: the checks above are all there is
        try:
            was, is_now = json.loads(before[key]), json.loads(now[key])
        except ValueError:
            was, is_now = {"(unreadable)": before[key]}, {}
        changed = sorted(k for k in set(was) | set(is_now) if was.get(k) != is_now.get(k))
        if changed:
            said = ", ".join(f"{k} {was.get(k)!r} -> {is_now.get(k)!r}" for k in changed[:3])
            raise ConfigError(
                f"{output} was recorded with another {what} ({said}); --resume continues "
                "the same sweep: give the same rig file and plan, or start a new recording"
            )


def _say_if_long(rig: RigConfig, plan: SweepPlan, todo: list[SweepPoint], console: Console) -> None:
    """A sweep planned over LONG_SWEEP_S says, before the rig moves, about how long its
    motion takes (a simulated rig's at its --speed) and how to stop it."""
    motion_s = plan.motion_s(rig.ramp.sine_ramp_cycles, todo)
    wall_s = motion_s / rig.daq.time_scale
    if wall_s <= LONG_SWEEP_S:
        return
    scaled = rig.daq.time_scale != 1.0
    console.print(
        f"sweep: {len(todo)} test{'s' * (len(todo) > 1)} of {plan.warmup_cycles} warm-up and "
        f"{plan.measured_cycles} measured cycles: about {duration_text(wall_s)} of motion"
        + (f" ({duration_text(motion_s)} of rig time at x{rig.daq.time_scale:g})" if scaled else "")
        + ", click changes and temperature waits on top. Ctrl-C stops safely and keeps what "
        "was recorded; --resume continues.",
        markup=False,
        highlight=False,
        soft_wrap=True,
    )
