"""`shockdyno demo`, `sweep` and `replay`."""

from __future__ import annotations

import argparse
import contextlib
import math
import time
from collections import deque
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from rich.console import Console
from rich.table import Table

from shockdyno import __version__
from shockdyno import units as units_mod
from shockdyno.commands.args import Subparsers, add_force, add_rig, add_seed, hint_unreachable
from shockdyno.commands.live import add_live_arguments, live_view
from shockdyno.errors import ConfigError, RecordingError, RigFault
from shockdyno.fit.file import fit_file
from shockdyno.fit.result import FitResult
from shockdyno.fit.validate import table4_rows
from shockdyno.lists import parse_clicks, parse_frequencies
from shockdyno.model.spec import DamperSpec, default_spec_path, load_spec
from shockdyno.model.stroke import CONSTANT_VELOCITY, WAVEFORMS, Stroke
from shockdyno.outputs import refuse_inputs
from shockdyno.record import open_recording
from shockdyno.record.lock import recording_lock
from shockdyno.record.reader import Recording
from shockdyno.record.types import TestMeta
from shockdyno.report.clickchart import spec_static_force_n
from shockdyno.rig.config import RigConfig, load_rig
from shockdyno.run.plan import (
    DESIGNS,
    SweepPlan,
    constant_velocity_strokes,
    frequencies_for_velocities,
    parse_adjust,
    parse_base,
    parse_velocities_mm_s,
    stroke_frequency_hz,
)
from shockdyno.run.recording import record_sweep
from shockdyno.run.refusals import MIN_FREQUENCY_HZ
from shockdyno.run.signals import stop_on_signals
from shockdyno.run.table import click_table
from shockdyno.simrig import start_sim_rig

if TYPE_CHECKING:  # imported when a live view starts (commands/live.py)
    from shockdyno.live.publisher import LivePublisher

REPO = Path(__file__).resolve().parents[3]


def repo_file(relative: str) -> Path:
    """A file shipped in the repository (rigs/, sim/), else relative to the current directory."""
    p = REPO / relative
    return p if p.exists() else Path(relative)


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


# --speed means one thing in every command (demo, sweep --start-sim, sim-rig, replay): how many
# simulated or recorded seconds pass per wall-clock second. It must be > 0; replay's "as fast as
# it can" is its own flag, --fast.
SPEED_HELP = "x real time: simulated seconds per wall-clock second"


def _band(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError("use LOW,HIGH in °C, e.g. 35,45") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise argparse.ArgumentTypeError(f"use LOW,HIGH in °C with LOW <= HIGH, got {text!r}")
    return lo, hi


def register(sub: Subparsers) -> None:
    _register_demo(sub)
    _register_sweep(sub)
    _register_replay(sub)


def _register_demo(sub: Subparsers) -> None:
    d = sub.add_parser(
        "demo",
        help="sweep the simulated rig, fit the model, write the recording and the report",
        description="Start the simulated rig, sweep clicks 0,3,...,21 at 0.5/1/1.5 Hz and 30 mm "
        "faster than real time, record to MCAP, fit and validate the model, write the report.",
    )
    d.add_argument("--out-dir", type=Path, default=Path("recordings"), help="output directory")
    d.add_argument("--clicks", default="0-21:3", help="click settings, e.g. 0-21:3 or 0,5,10")
    d.add_argument("--speed", type=float, default=50.0, help=SPEED_HELP)
    add_seed(d, "the simulated rig's noise")
    d.add_argument("--cycles", type=int, default=5, help="measured cycles per test")
    d.add_argument("--no-fit", action="store_true", help="record and report only")
    d.add_argument("--table", action="store_true", help="only print the model's click table")
    d.set_defaults(func=cmd_demo)


def _register_sweep(sub: Subparsers) -> None:
    s = sub.add_parser(
        "sweep",
        help="run a click sweep on a rig and record it to MCAP",
        description="For each click setting: set the adjuster; for each frequency: ramp in, "
        "warm-up cycles, measured cycles, ramp out. Ctrl-C stops safely and keeps what was "
        "recorded; --resume continues from the first untested point.",
    )
    add_rig(s)
    _add_plan(s)
    s.add_argument(
        "-o", "--output", type=Path, required=True, help="recording, e.g. recordings/X.mcap"
    )
    s.add_argument("--resume", action="store_true", help="continue an interrupted sweep")
    add_force(s, "an existing recording")
    s.add_argument("--damper-id", default="", help="stored in the recording's metadata")
    s.add_argument("--operator", default="", help="stored in the recording's metadata")
    s.add_argument("--notes", default="", help="stored in the recording's metadata")
    _add_start_sim(s)
    units_mod.add_argument(s, "the end-of-test lines")
    add_live_arguments(s, "the sweep")
    s.set_defaults(func=cmd_sweep)


def _add_plan(s: argparse.ArgumentParser) -> None:
    """What the sweep runs: the clicks, the motion, the gas, the cycles, the temperature."""
    s.add_argument(
        "--clicks",
        help="click settings, e.g. 0-21:3 or 0,5,10; default every click of the spec (0-21)",
    )
    _add_adjust(s)
    by = s.add_mutually_exclusive_group()
    by.add_argument("--freq", default="0.5,1,1.5", help="Hz, e.g. 0.5,1,1.5 or 0.5-2:0.5")
    by.add_argument(
        "--velocities-mm-s",
        metavar="V,...",
        help="plan by target peak velocity instead of --freq, e.g. 25,50,100,200,300: each "
        "frequency is v / (2π A) at --amplitude-mm, refused beyond the rig file's limits",
    )
    s.add_argument(
        "--waveform",
        choices=WAVEFORMS,
        default="sine",
        help="sine, or a constant-velocity stroke planned by --velocities-mm-s: triangle "
        "(constant velocity between reversals) or trapezoid (reversals at "
        "--reversal-accel-m-s2); docs/report.md",
    )
    s.add_argument(
        "--reversal-accel-m-s2",
        type=_positive_float,
        metavar="A",
        help="trapezoid: the reversals' acceleration, m/s² (default: each speed's, so that "
        "a reversal takes the outer 10 %% of the amplitude)",
    )
    s.add_argument("--amplitude-mm", type=_positive_float, default=30.0, help="sine amplitude")
    s.add_argument("--gas-clicks", type=int, default=0, help="gas-bottle click setting")
    s.add_argument(
        "--gas-pressure-bar",
        type=_positive_float,
        help="the damper's gas charge as set, bar absolute: stored with every test, so "
        "diagnose can tell air (its lag falls as the charge rises) from a sensor lag",
    )
    s.add_argument(
        "--no-gas-measure",
        action="store_true",
        help="skip the static gas-force measurement at mid-stroke at the start and after each "
        "click change (reports then estimate it from the sine's reversals)",
    )
    s.add_argument("--warmup-cycles", type=int, default=2, help="cycles before the measured ones")
    s.add_argument("--cycles", type=int, default=5, help="measured cycles per test")
    s.add_argument("--temp-band-c", type=_band, help="wait until LOW <= T <= HIGH before each test")


def _add_start_sim(s: argparse.ArgumentParser) -> None:
    s.add_argument(
        "--start-sim",
        action="store_true",
        help="start the simulated rig in-process with this rig file (no separate sim-rig)",
    )
    s.add_argument("--speed", type=float, default=1.0, help=f"with --start-sim: {SPEED_HELP}")
    s.add_argument("--scenario", type=Path, help="with --start-sim: extra physics, sim/scenarios/")
    add_seed(s, "the simulated rig's noise, with --start-sim")


def _register_replay(sub: Subparsers) -> None:
    r = sub.add_parser("replay", help="play a recording through the live view")
    r.add_argument("recording", type=Path)
    r.add_argument("--speed", type=float, default=1.0, help="x real time: recorded seconds per "
                   "wall-clock second")  # fmt: skip
    r.add_argument("--fast", action="store_true", help="play as fast as it can (no waiting)")
    units_mod.add_argument(r, "the end-of-test lines")
    add_live_arguments(r, "the recording")
    r.set_defaults(func=cmd_replay)


SAFETY_SHARE = 0.95  # of the rig's velocity limit a planned sine may reach


def _frequencies(args: argparse.Namespace, rig: RigConfig | None) -> list[float]:
    """--freq as given, or the frequencies that reach --velocities-mm-s at the amplitude."""
    text = getattr(args, "velocities_mm_s", None)
    if text is None:
        return parse_frequencies(getattr(args, "freq", "0.5,1,1.5"))
    amplitude_m = getattr(args, "amplitude_mm", 30.0) / 1e3
    velocities = parse_velocities_mm_s(text)
    slowest = min(velocities) / (2 * math.pi * amplitude_m)
    if slowest < MIN_FREQUENCY_HZ:
        raise ConfigError(
            f"--velocities-mm-s: {min(velocities) * 1e3:g} mm/s at {amplitude_m * 1e3:g} mm "
            f"needs {slowest:.3g} Hz, a cycle of {1 / slowest / 3600:.3g} h; the slowest "
            "planned is one cycle in 10 min (use a smaller --amplitude-mm)"
        )
    if rig is not None:
        # 5 % under the limit: the safety monitor watches measured, noisy velocities, and
        # a sine planned at the limit itself is refused by the session at its start.
        limit = SAFETY_SHARE * rig.limits.velocity_m_s
        too_fast = [v for v in velocities if v > limit]
        if too_fast:
            raise ConfigError(
                f"--velocities-mm-s: {too_fast[0] * 1e3:g} mm/s exceeds "
                f"{limit * 1e3:g} mm/s, 95 % of the rig's limit of "
                f"{rig.limits.velocity_m_s * 1e3:g} mm/s ({rig.source} limits.velocity_m_s)"
            )
    if rig is not None:
        f_max = rig.daq.sample_rate_hz / 20
        exact = [float(f"{v / (2 * math.pi * amplitude_m):.5g}") for v in velocities]
        for v, f in zip(velocities, exact, strict=True):
            if f > f_max:
                raise ConfigError(
                    f"--velocities-mm-s: {v * 1e3:g} mm/s at {amplitude_m * 1e3:g} mm needs "
                    f"{f:g} Hz, above the {f_max:g} Hz the DAQ's {rig.daq.sample_rate_hz:g} Hz "
                    "allows (20 samples per cycle); use a larger --amplitude-mm"
                )
    # The top target gets its margin (run/plan.py), within the rig's velocity and the
    # DAQ's 20 samples per cycle.
    cap = math.inf
    if rig is not None:
        f_max = rig.daq.sample_rate_hz / 20
        # 5 % under the limit: the safety monitor watches measured, noisy velocities.
        cap = SAFETY_SHARE * min(rig.limits.velocity_m_s, 2 * math.pi * amplitude_m * f_max)
    return frequencies_for_velocities(velocities, amplitude_m, cap)


def _strokes(args: argparse.Namespace, rig: RigConfig | None) -> list[Stroke]:
    """--waveform triangle | trapezoid: one stroke per --velocities-mm-s (none for a sine),
    each refused here in one line when the rig file's limits or the DAQ forbid it."""
    waveform = getattr(args, "waveform", "sine")
    accel = getattr(args, "reversal_accel_m_s2", None)
    if accel is not None and waveform != "trapezoid":
        raise ConfigError("--reversal-accel-m-s2 applies to --waveform trapezoid only")
    if waveform not in CONSTANT_VELOCITY:
        return []
    text = getattr(args, "velocities_mm_s", None)
    if text is None:
        raise ConfigError(
            f"--waveform {waveform} is planned by speed: give --velocities-mm-s "
            "(e.g. 25,50,100), not --freq"
        )
    amplitude_m = getattr(args, "amplitude_mm", 30.0) / 1e3
    strokes = constant_velocity_strokes(waveform, parse_velocities_mm_s(text), amplitude_m, accel)
    for s in strokes:
        f = stroke_frequency_hz(s)
        if f < MIN_FREQUENCY_HZ:
            raise ConfigError(
                f"--velocities-mm-s: {s.velocity_m_s * 1e3:g} mm/s over ±{amplitude_m * 1e3:g} "
                f"mm is a cycle of {1 / f / 60:.3g} min; the slowest planned is one cycle in "
                "10 min (use a smaller --amplitude-mm)"
            )
        if rig is None:
            continue
        limit = SAFETY_SHARE * rig.limits.velocity_m_s
        if s.velocity_m_s > limit:
            raise ConfigError(
                f"--velocities-mm-s: {s.velocity_m_s * 1e3:g} mm/s exceeds {limit * 1e3:g} "
                f"mm/s, 95 % of the rig's limit of {rig.limits.velocity_m_s * 1e3:g} mm/s "
                f"({rig.source} limits.velocity_m_s)"
            )
        if f > rig.daq.sample_rate_hz / 20:
            raise ConfigError(
                f"--velocities-mm-s: {s.velocity_m_s * 1e3:g} mm/s over ±{amplitude_m * 1e3:g} "
                f"mm is {f:g} Hz, above the {rig.daq.sample_rate_hz / 20:g} Hz the DAQ allows "
                "(20 samples per cycle); use a larger --amplitude-mm"
            )
    return strokes


def _add_adjust(s: argparse.ArgumentParser) -> None:
    """A damper with several adjusters (its spec's [adjuster.NAME]): docs/adjusters.md."""
    s.add_argument(
        "--spec",
        metavar="PATH",
        help="the damper's spec TOML: its adjusters and click ranges (and, with --start-sim, "
        "the simulated damper); default sim/ohlins-s46.toml",
    )
    s.add_argument(
        "--adjust",
        metavar="NAME=CLICKS",
        action="append",
        default=[],
        help="for a spec with [adjuster.NAME] tables, instead of --clicks: one adjuster's "
        "settings, repeated for each, e.g. --adjust compression=0-20:5 --adjust rebound=0,10,20",
    )
    s.add_argument(
        "--base",
        metavar="NAME=CLICKS",
        action="append",
        default=[],
        help="with --adjust, one-at-a-time: hold this adjuster here while the others move "
        "(repeatable; default the middle of its --adjust list)",
    )
    s.add_argument(
        "--design",
        choices=DESIGNS,
        default=DESIGNS[0],
        help="with --adjust: each adjuster through its list with the others at the middle of "
        "theirs (one-at-a-time), or every combination (factorial)",
    )


def _clicks_text(args: argparse.Namespace, max_clicks: int) -> str:
    """--clicks as given (demo's default), or every click of the damper's one adjuster."""
    given: str | None = getattr(args, "clicks", None)
    return given if given is not None else f"0-{max_clicks}"


def _adjust_plan(args: argparse.Namespace, spec: DamperSpec, plan: SweepPlan) -> SweepPlan:
    """The plan over the spec's adjusters (`--adjust`), or the one rod adjuster's as given."""
    items = list(getattr(args, "adjust", []) or [])
    if not spec.adjusters:
        if items or getattr(args, "base", []):
            raise ConfigError(
                f"--adjust, --base: the damper {spec.name} has one rod adjuster (no "
                "[adjuster.NAME] in its spec): use --clicks"
            )
        return plan
    if not items or getattr(args, "clicks", None) is not None:
        names = ", ".join(spec.adjuster_names)
        raise ConfigError(
            f"the damper {spec.name} has adjusters {names}: give each with --adjust NAME=CLICKS "
            f"(e.g. --adjust {spec.adjuster_names[0]}=0-20:5), not --clicks"
        )
    ranges = {n: spec.adjuster_law(n).max_clicks for n in spec.adjuster_names}
    held = parse_base(getattr(args, "base", []) or [], ranges)
    return replace(
        plan, clicks=(), adjust=parse_adjust(items, ranges), design=args.design, held=held
    )


def _plan(
    args: argparse.Namespace, max_clicks: int, max_gas_clicks: int, rig: RigConfig | None = None
) -> SweepPlan:
    gas = getattr(args, "gas_clicks", 0)
    if not 0 <= gas <= max_gas_clicks:
        raise ConfigError(f"gas-bottle clicks must be 0-{max_gas_clicks}, got {gas}")
    strokes = _strokes(args, rig)
    return SweepPlan(
        clicks=tuple(parse_clicks(_clicks_text(args, max_clicks), max_clicks)),
        frequencies_hz=(
            tuple(stroke_frequency_hz(s) for s in strokes)
            if strokes
            else tuple(_frequencies(args, rig))
        ),
        strokes=tuple(strokes),
        amplitude_m=getattr(args, "amplitude_mm", 30.0) / 1e3,
        gas_clicks=gas,
        warmup_cycles=getattr(args, "warmup_cycles", 2),
        measured_cycles=args.cycles,
        temperature_band_c=getattr(args, "temp_band_c", None),
        gas_pressure_pa=(
            None if getattr(args, "gas_pressure_bar", None) is None else args.gas_pressure_bar * 1e5
        ),
        measure_gas=not getattr(args, "no_gas_measure", False),
    )


def _click_ranges(spec: DamperSpec) -> tuple[int, int]:
    return int(spec.compression_bleed.max_clicks), int(spec.max_gas_clicks)


def _metadata(args: argparse.Namespace, rig: RigConfig, spec: str) -> dict[str, str]:
    return {
        "damper_id": getattr(args, "damper_id", "") or "",
        "operator": getattr(args, "operator", "") or "",
        "notes": getattr(args, "notes", "") or "",
        "rig": rig.name,
        "damper_spec": spec,
        "software": f"shockdyno {__version__}",
        "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


@hint_unreachable
def cmd_sweep(args: argparse.Namespace) -> int:
    console = Console()
    # No file the sweep reads may become its recording, --force or not.
    spec_path = Path(args.spec) if args.spec else default_spec_path()
    read = [args.rig, spec_path, *([args.scenario] if args.scenario else [])]
    refuse_inputs(Path(args.output), read, flag="-o")
    if args.start_sim or args.live:  # refused before the sim or the live view starts
        with recording_lock(Path(args.output)):  # another writer is named first
            if Path(args.output).exists() and not (args.force or args.resume):
                raise RecordingError(
                    f"{args.output} exists: use --force to overwrite or --resume to continue"
                )
    rig = load_rig(args.rig)
    spec = load_spec(spec_path)
    plan = _adjust_plan(args, spec, _plan(args, *_click_ranges(spec), rig))
    with contextlib.ExitStack() as stack:
        stack.enter_context(stop_on_signals())  # SIGTERM and SIGHUP stop like Ctrl-C
        live = stack.enter_context(live_view(args, console))  # before any rig: a busy port
        spec_used = ""  # a real rig's damper is whatever is mounted
        if args.start_sim:
            sim = stack.enter_context(
                start_sim_rig(
                    rig,
                    spec_path=spec_path,
                    scenario=args.scenario,
                    speed=args.speed,
                    seed=args.seed,
                )
            )
            for endpoint in sim.endpoints:
                console.print(endpoint)
            rig, spec_used = sim.rig_config(), str(spec_path)
        meta = _metadata(args, rig, spec_used)
        result = record_sweep(rig, plan, args.output, metadata=meta, overwrite=args.force,
                              resume=args.resume, console=console,
                              units=units_mod.get(args.units), live=live)  # fmt: skip
    console.print(f"recording: {args.output}", soft_wrap=True)
    if result is not None and result.degraded:
        listed = ", ".join(str(m.index) for m in result.degraded)
        raise RigFault(
            f"{len(result.degraded)} tests degraded (tests {listed}; see `shockdyno info`): "
            "they are not complete; --resume runs them again"
        )
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    if not args.speed > 0:
        raise ConfigError(f"--speed must be > 0, got {args.speed:g}; --fast plays without waiting")
    # Imported when run: +7 ms CPU at every command's start-up (measured).
    from shockdyno.run.liveview import LiveView

    rec = open_recording(args.recording).require_recording()
    console = Console()
    if rec.truncated:
        console.print("[yellow]recording was cut off; replaying every complete test[/]")
    chunk = 100
    with (
        live_view(args, console, blocking=True) as live,
        LiveView(
            len(rec.tests), console=console, title="replay", units=units_mod.get(args.units)
        ) as view,
    ):
        records = _ReplayRecords(rec, live)
        if live is not None:
            console.print("waiting for a viewer to connect (Ctrl-C to stop)")
            live.server.wait_for_viewer()
        for i, meta in enumerate(rec.tests):
            samples = rec.samples(i)  # as the DAQ delivered them: the motion bit too
            view.start_test(meta)
            records.begin(meta, float(samples.t_s[0]) if len(samples) else 0.0)
            for lo in range(0, len(samples), chunk):
                block = samples.slice(lo, lo + chunk)
                view.update(block)
                if live is not None:
                    records.until(float(block.t_s[-1]))
                    live.write_samples(block)
                if not args.fast and len(block) > 1:
                    time.sleep(float(block.t_s[-1] - block.t_s[0]) / args.speed)
            view.end_test(meta)
            records.end(meta)
        if live is not None:
            records.until(math.inf)  # the session's end: stop, centre, disable
    return 0


class _ReplayRecords:
    """The recording's test records, actuator records and events, sent to the live view
    in step with the samples (replay --live)."""

    def __init__(self, rec: Recording, live: LivePublisher | None) -> None:
        self.live = live
        self.actuator = deque(sorted(rec.actuator, key=lambda r: r[0]))
        self.events = deque(sorted(rec.events, key=lambda r: r[0]))

    def begin(self, meta: TestMeta, t_s: float) -> None:
        if self.live is not None:
            self.until(t_s)
            self.live.begin_test(replace(meta, status="running"))

    def until(self, t_s: float) -> None:
        if self.live is None:  # called only with a live view
            return
        while self.actuator and self.actuator[0][0] <= t_s:
            t, fields = self.actuator.popleft()
            kept = {k: v for k, v in fields.items() if k not in ("t_s", "test")}
            self.live.write_actuator(t, kept)
        while self.events and self.events[0][0] <= t_s:
            self.live.write_event(*self.events.popleft())

    def end(self, meta: TestMeta) -> None:
        if self.live is not None:
            self.live.end_test(meta)


def cmd_demo(args: argparse.Namespace) -> int:
    console = Console()
    spec_path = default_spec_path()
    spec = load_spec(spec_path)
    if args.table:
        Console(width=max(console.width, 120)).print(click_table(spec))
        return 0
    # Imported when run: +460 ms CPU at start-up (matplotlib).
    from shockdyno.report import build_report

    out: Path = args.out_dir
    rec_path = out / "demo.mcap"
    report_dir = out / "demo-report"
    plan = _plan(args, *_click_ranges(spec))
    rig = load_rig(repo_file("rigs/sim.toml"))
    console.rule("shockdyno demo: click sweep on the simulated rig")
    t0 = time.perf_counter()
    with stop_on_signals(), start_sim_rig(rig, speed=args.speed, seed=args.seed) as sim:
        for endpoint in sim.endpoints:
            console.print(endpoint)
        live_rig = sim.rig_config()
        meta = _metadata(args, live_rig, str(spec_path))
        meta.update(damper_id="simulated ohlins-s46", operator="demo")
        record_sweep(live_rig, plan, rec_path, metadata=meta, overwrite=True, console=console)
    console.print(f"sweep recorded in {time.perf_counter() - t0:.1f} s: {rec_path}", soft_wrap=True)
    tests = open_recording(rec_path).load_all()
    fit = None if args.no_fit else _demo_fit(rec_path, spec_path, out, args.seed, console)
    with console.status("report") as status:
        index = build_report(
            tests,
            report_dir,
            title="shockdyno demo: simulated Öhlins S46 click sweep",
            metadata=meta,
            fit=fit,
            gas_force_n=None if fit is not None else _static_force(spec),
            progress=lambda stage: status.update(f"report: {stage}"),
        )
    console.rule("done")
    console.print(f"recording: {rec_path}", soft_wrap=True)  # paths stay whole for copy-paste
    console.print(f"report:    {index}", soft_wrap=True)
    return 0


def _static_force(spec: DamperSpec) -> float:
    return spec_static_force_n(spec)


def _demo_fit(rec_path: Path, spec_path: Path, out: Path, seed: int, console: Console) -> FitResult:
    """`shockdyno fit` of the demo's recording: the result names it (info.recording), so
    `report demo.mcap --fit demo-fit.json` and `diagnose --fit` accept it."""
    console.rule("fit: globals, bleed areas per click, trend, validation")
    t0 = time.perf_counter()
    fitted, _ = fit_file(rec_path, spec=str(spec_path), optimizer="fast", seed=seed)
    result: FitResult = fitted  # fit_file is typed Any (fit/)
    fit_path = out / "demo-fit.json"
    result.save(fit_path)
    console.print(f"fit done in {time.perf_counter() - t0:.1f} s: {fit_path}", soft_wrap=True)
    header, rows = table4_rows(result)
    table = Table(title="Table 4 analogue: error measures, proposed vs Talbott")
    for h in header:
        table.add_column(h, justify="right")
    for row in rows:
        table.add_row(*row)
    Console(width=max(console.width, 100)).print(table)
    return result
