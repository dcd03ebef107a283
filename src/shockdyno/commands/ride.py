"""`shockdyno ride`: the quarter-car ride study on the fitted damper (docs/ride.md)."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TypeVar

from shockdyno.atomic import staged_dir
from shockdyno.commands.args import Subparsers, add_force, add_seed
from shockdyno.errors import ConfigError
from shockdyno.fit.result import FitResult
from shockdyno.lists import parse_floats, parse_ints, parse_letters
from shockdyno.model.quarter_car import QuarterCar
from shockdyno.model.road import DEFAULT_BAND_RAD_M
from shockdyno.outputs import check_output, check_report_dir, write_output
from shockdyno.progress import StageProgress
from shockdyno.report.documents import FlaggedRun, ride_text
from shockdyno.ride.study import RideConfig, RideResult, run_study

T = TypeVar("T")


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "ride",
        help="quarter car with the fitted damper on ISO 8608 roads (RMS, Wk RMS, PSD)",
        description=(
            "Quarter-car ride study (paper eq. 18-24, Table 7, Figs. 17-20): sprung-mass "
            "acceleration RMS, ISO 2631-1 Wk-weighted RMS and PSD for clicks x roads x "
            "speeds, with the damper force from the fitted damper model."
        ),
    )
    p.add_argument("--fit", help="fit result JSON (from `shockdyno fit`)")
    p.add_argument("--clicks", default="5,10,15", help="rod clicks, e.g. 5,10,15 or 0-21:3")
    p.add_argument(
        "--adjuster",
        metavar="NAME",
        help="a fit of a damper with several adjusters: --clicks are this adjuster's, the "
        "others at the sweep's base (docs/adjusters.md)",
    )
    p.add_argument("--roads", default="A,B,C,D,E", help="ISO 8608 classes, e.g. A-E or A,C,E")
    p.add_argument("--speeds-kmh", default="20,60,80,120", help="km/h, e.g. 20,60 or 20-120:20")
    p.add_argument(
        "--json", required=True, help="write the result here (docs/ride.md; - for stdout)"
    )
    add_force(p, "an existing --json file or --report page")
    p.add_argument(
        "--report",
        metavar="DIR",
        help="write DIR/index.html with the figures, Table 7 (also table7.md) and the PSD CSV",
    )
    p.add_argument(
        "--model",
        choices=("proposed", "talbott"),
        default="proposed",
        help="bleed areas of the proposed model (A_bc, A_bt) or Talbott's (one A_b)",
    )
    p.add_argument(
        "--linear-damper-ns-m",
        type=float,
        help="replace the damper with F = c v (N·s/m); --fit not needed",
    )
    p.add_argument("--duration-s", type=float, default=60.0, help="record length after warm-up")
    p.add_argument("--warmup-s", type=float, default=5.0, help="discarded start, s")
    p.add_argument("--dt-ms", type=float, default=1.0, help="fixed RK4 step, ms")
    add_seed(p, "the road phases")
    p.add_argument("--waviness", type=float, default=2.0, help="ISO 8608 waviness w")
    p.add_argument(
        "--band-rad-per-m",
        default=f"{DEFAULT_BAND_RAD_M[0]:.6g},{DEFAULT_BAND_RAD_M[1]:.6g}",
        help="road band Ω_min,Ω_max in rad/m (default ISO 8608's 0.011-2.83 cycles/m)",
    )
    car = QuarterCar()
    p.add_argument("--sprung-mass-kg", type=float, default=car.sprung_mass_kg)
    p.add_argument("--unsprung-mass-kg", type=float, default=car.unsprung_mass_kg)
    p.add_argument("--spring-n-per-m", type=float, default=car.spring_n_m)
    p.add_argument("--tyre-n-per-m", type=float, default=car.tyre_n_m)
    p.add_argument(
        "--travel-mm",
        type=float,
        default=50.0,
        help="damper travel either side of static ride height; longer strokes are flagged "
        "(default 50)",
    )
    p.add_argument(
        "--no-step-check",
        action="store_true",
        help="skip repeating the extreme runs at half the step",
    )
    p.set_defaults(func=handle)


def config_from_args(args: argparse.Namespace) -> RideConfig:
    band = parse_floats(args.band_rad_per_m, "--band-rad-per-m")
    if len(band) != 2:
        raise ConfigError("--band-rad-per-m takes two numbers: Ω_min,Ω_max")
    for name in ("duration_s", "warmup_s", "dt_ms", "waviness"):
        if not math.isfinite(getattr(args, name)):
            raise ConfigError(f"--{name.replace('_', '-')} must be a finite number")
    return RideConfig(
        clicks=tuple(parse_ints(args.clicks, "--clicks")),
        roads=tuple(parse_letters(args.roads, "--roads")),
        speeds_kmh=tuple(parse_floats(args.speeds_kmh, "--speeds-kmh")),
        car=QuarterCar(
            args.sprung_mass_kg, args.unsprung_mass_kg, args.spring_n_per_m, args.tyre_n_per_m
        ),
        duration_s=args.duration_s,
        warmup_s=args.warmup_s,
        dt_s=args.dt_ms * 1e-3,
        band_rad_m=(band[0], band[1]),
        waviness=args.waviness,
        seed=args.seed,
        linear_damper_ns_m=args.linear_damper_ns_m,
        model=args.model,
        step_check=not args.no_step_check,
        travel_m=args.travel_mm * 1e-3,
    )


def _adjuster_line(fit: FitResult, args: argparse.Namespace) -> FitResult:
    """The fit along the named adjuster (a damper with several), or as it is."""
    names = fit.adjuster_names()
    name = getattr(args, "adjuster", None)
    if names and name is None:
        raise ConfigError(
            f"--fit {args.fit}: a damper with adjusters {', '.join(names)}: name the one whose "
            f"--clicks the study sweeps with --adjuster (e.g. --adjuster {names[0]})"
        )
    if name is not None and name not in names:
        have = ", ".join(names) or "the one rod adjuster (no --adjuster)"
        raise ConfigError(f"--adjuster {name}: the fit has {have}")
    return fit.for_adjuster(name) if name is not None else fit


def summary(result: RideResult) -> str:
    """One line per speed and damper: the RMS on each road (m/s²)."""
    cfg = result.config
    lines = [
        f"RMS sprung-mass acceleration, m/s² (Wk-weighted in brackets); "
        f"T = {cfg.duration_s:g} s, dt = {cfg.dt_s * 1e3:g} ms"
    ]
    lines.append("speed  damper      " + "".join(f"{r:>17}" for r in cfg.roads))
    for v in cfg.speeds_kmh:
        for c in dict.fromkeys(r.clicks for r in result.runs):
            cells = "".join(
                f"{result.rms_of(c, r, v):>8.3f} ({result.rms_wk_of(c, r, v):.3f})"
                for r in cfg.roads
            )
            label = "linear" if c is None else f"{c} clicks"
            lines.append(f"{v:>5g}  {label:<10}  {cells}")
    if result.step_check is not None:
        lines.append(
            f"step check: RMS changes by at most "
            f"{result.step_check.max_relative_change:.2e} at dt/2"
        )
    return "\n".join(lines)


def _runs(flagged: Sequence[FlaggedRun]) -> str:
    shown = [
        f"{'linear' if r.clicks is None else str(r.clicks) + ' clicks'} "
        f"{r.road} {r.speed_kmh:g} km/h"
        for r in flagged[:4]
    ]
    more = f" and {len(flagged) - 4} more" if len(flagged) > 4 else ""
    return ", ".join(shown) + more


def warnings(result: RideResult) -> list[str]:
    """Lines for the console: runs outside the model's validity, interpolated clicks."""
    flags = result.flags()
    out = []
    n = len(result.runs)
    tyre, stroke = flags.tyre_leaves_road, flags.stroke_exceeds_travel
    if tyre:
        out.append(
            f"warning: the tyre leaves the road in {len(tyre)} of {n} runs (the linear tyre "
            f"is pulled; outside the model's validity): {_runs(tyre)}"
        )
    if stroke:
        out.append(
            f"warning: the damper stroke exceeds its travel (±{result.config.travel_m * 1e3:g} "
            f"mm, --travel-mm) in {len(stroke)} of {n} runs: {_runs(stroke)}"
        )
    if flags.interpolated_clicks:
        clicks = ", ".join(map(str, flags.interpolated_clicks))
        out.append(
            f"note: bleed areas at {clicks} clicks are interpolated from the fit's trend "
            "(no test at that setting)"
        )
    return out


def handle(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    inputs = [args.fit] if args.fit else []
    out = check_output(args.json, force=args.force, inputs=inputs)
    if args.report:
        check_report_dir(Path(args.report), inputs, args.force)
    fit = None
    if config.linear_damper_ns_m is None:
        if not args.fit:
            raise ConfigError("--fit FIT.json is required (or --linear-damper-ns-m C)")
        fit = FitResult.load(args.fit).require_usable(f"--fit {args.fit}")
        fit = _adjuster_line(fit, args)
    with StageProgress("ride") as progress:
        result = run_study(config, fit, args.fit, progress=progress)
    # The recording the fit came from, so a report can tell a ride of another damper.
    result.fit_recording = fit.info.recording if fit is not None else None
    try:
        text = ride_text(result.doc())
    except ValueError as exc:
        raise ConfigError(f"the ride result cannot be written as JSON ({exc})") from None
    write_output(args.json, text, force=args.force, inputs=inputs)
    # With --json -, stdout carries only the JSON; the human summary goes to stderr.
    human = sys.stderr if out is None else sys.stdout
    print(summary(result), file=human)
    for line in warnings(result):
        print(line, file=human)
    print(f"wrote {'stdout' if out is None else out}", file=human)
    if args.report:
        # Imported when used: +430 ms CPU at start-up (matplotlib).
        from shockdyno.ride.plots import write_report

        with staged_dir(Path(args.report)) as folder:  # whole, or not at all
            files = write_report(result, folder)
        print(f"report: {Path(args.report) / 'index.html'} ({len(files)} files)", file=human)
    return 0
