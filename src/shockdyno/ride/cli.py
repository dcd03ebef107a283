"""`shockdyno ride`: the quarter-car ride study on the fitted damper (docs/ride.md)."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TypeVar

from shockdyno.errors import ConfigError
from shockdyno.fit.result import FitResult
from shockdyno.lists import parse_floats, parse_ints, parse_letters
from shockdyno.model.quarter_car import QuarterCar
from shockdyno.model.road import DEFAULT_BAND_RAD_M
from shockdyno.progress import StageProgress
from shockdyno.ride.study import RideConfig, RideResult, run_study

T = TypeVar("T")


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
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
    p.add_argument("--roads", default="A,B,C,D,E", help="ISO 8608 classes, e.g. A-E or A,C,E")
    p.add_argument("--speeds-kmh", default="20,60,80,120", help="km/h, e.g. 20,60 or 20-120:20")
    p.add_argument("--json", required=True, help="write the result here (docs/ride.md)")
    p.add_argument("--report", help="directory for figures, Table 7 and the PSD CSV")
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
    p.add_argument("--seed", type=int, default=0, help="road phases seed")
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
    )


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
            f"{result.step_check['max_relative_change']:.2e} at dt/2"
        )
    return "\n".join(lines)


def handle(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    fit = None
    if config.linear_damper_ns_m is None:
        if not args.fit:
            raise ConfigError("--fit FIT.json is required (or --linear-damper-ns-m C)")
        fit = FitResult.load(args.fit)
    out = Path(args.json)
    if out.is_dir():
        raise ConfigError(f"--json names a directory: {out}")
    if not out.parent.exists():
        raise ConfigError(f"directory of --json does not exist: {out.parent}")
    with StageProgress("ride") as progress:
        result = run_study(config, fit, args.fit, progress=progress)
    try:
        out.write_text(json.dumps(result.to_json(), indent=2, allow_nan=False) + "\n")
    except OSError as exc:
        raise ConfigError(f"cannot write {out}: {exc.strerror}") from None
    print(summary(result))
    print(f"wrote {out}")
    if args.report:
        from shockdyno.ride.plots import write_report

        files = write_report(result, args.report)
        print(f"wrote {len(files)} report files to {args.report}")
    return 0
