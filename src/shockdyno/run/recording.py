"""Run a sweep plan on a rig into a recording: resume checks, refusals before the rig
is touched, the live view, the session and the writer, and a teardown that is recorded.

The commands (`sweep`, `demo`) call `record_sweep`; it holds no argument parsing.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rich.console import Console

from shockdyno.errors import ConfigError, RecordingError
from shockdyno.outputs import check_output
from shockdyno.run.plan import SweepPlan
from shockdyno.units import SI, Units

if TYPE_CHECKING:
    from shockdyno.rig.config import RigConfig


def record_sweep(rig: RigConfig, plan: SweepPlan, output: Path, **options: Any) -> Any:
    """Run the plan on the rig into the recording; returns the SweepResult (`options`:
    `_record_sweep`'s). The recording has one writer: a second sweep, resume or --force
    on it is refused (record/lock.py)."""
    from shockdyno.record.lock import recording_lock

    with recording_lock(output):
        return _record_sweep(rig, plan, output, **options)


def _record_sweep(
    rig: RigConfig,
    plan: SweepPlan,
    output: Path,
    *,
    metadata: dict[str, str],
    overwrite: bool = False,
    resume: bool = False,
    console: Console | None = None,
    units: Units = SI,
) -> Any:
    """Run the plan on the rig into the recording; returns the SweepResult."""
    from shockdyno.record import RecordingWriter, open_recording
    from shockdyno.run.liveview import LiveView
    from shockdyno.run.refusals import check_sine
    from shockdyno.run.session import RigSession, exit_reason
    from shockdyno.run.sweep import run_sweep

    console = console or Console()
    done: set[tuple[int, int, float]] = set()
    first_index = 0
    if resume:
        if not output.exists():
            raise RecordingError(f"nothing to resume: {output} does not exist")
        previous = open_recording(output).require_recording()
        _check_resume_matches(previous.tests, plan, output)
        _check_same_damper(previous.metadata, metadata, output)
        done = previous.completed_keys()
        first_index = len(previous.tests)
        console.print(
            f"resuming {output}: {len(done)} tests done, {len(plan.remaining(done))} to go"
        )
    elif output.exists() and not overwrite:
        raise RecordingError(f"{output} exists: use --force to overwrite or --resume to continue")
    todo = plan.remaining(done)
    if not todo:
        console.print("nothing left to run")
        return None
    # Everything that can be refused is refused here, before the rig is touched.
    for frequency in plan.frequencies_hz:
        check_sine(rig, plan.amplitude_m, frequency, plan.warmup_cycles, plan.measured_cycles)
    if rig.adjuster == "operator" and not sys.stdin.isatty():
        raise ConfigError(
            f"{rig.source}: the adjuster is set by an operator, who confirms each setting at a "
            "terminal; run the sweep from a terminal (stdin is not one)"
        )
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecordingError(
            f"-o {output}: cannot create {output.parent} ({exc.strerror})"
        ) from None
    # The recording must be creatable before the ram moves (found by a probe file now).
    check_output(output, force=True, flag="-o")

    view = LiveView(len(todo), console=console, units=units)

    def prompt(message: str) -> None:
        with view.paused():  # hold the live display while the operator reads and answers
            console.input(f"[bold yellow]{message}[/] - press Enter when done ")

    # Connect before creating the file: a rig that does not answer leaves no empty recording.
    with (
        view,
        RigSession(rig, prompt=prompt) as session,
        RecordingWriter(
            output, metadata=metadata, rig_toml=rig.raw_toml, overwrite=overwrite, resume=resume
        ) as writer,
    ):
        session.record_events(writer.write_event)
        try:
            return run_sweep(
                session,
                plan,
                writer,
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


def _check_resume_matches(tests: list[Any], plan: SweepPlan, output: Path) -> None:
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


def _check_same_damper(before: dict[str, str], now: dict[str, str], output: Path) -> None:
    """One recording set holds one damper, measured by one operator."""
    for key, flag in (("damper_id", "--damper-id"), ("operator", "--operator")):
        if before.get(key, "") != now.get(key, ""):
            raise ConfigError(
                f"{output} was recorded with {key} {before.get(key, '')!r}; resuming with "
                f"{flag} {now.get(key, '')!r} would mix two in one set (give the same {flag})"
            )
