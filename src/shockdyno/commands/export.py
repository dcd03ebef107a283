"""Command `export`: a recording to the CSV exchange format, or a fit to damper tables.

It sits above record/ and ride/ (it reads a recording or a fit and writes what either
exports), so neither package imports the other for it.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shockdyno import __version__
from shockdyno.commands.args import Subparsers, add_force, require_recording
from shockdyno.errors import ConfigError
from shockdyno.fit.file import MAX_FORCE_N
from shockdyno.fit.result import FitResult
from shockdyno.lists import parse_floats, parse_ints
from shockdyno.model.kinematics import differentiate
from shockdyno.outputs import check_output
from shockdyno.record import adjusters
from shockdyno.record.csv_export import export_csv
from shockdyno.record.reader import open_recording
from shockdyno.result_files import starts_as_mcap
from shockdyno.ride.damper_table import (
    IMPERIAL_SPEEDS_M_S,
    UNITS,
    ClickTable,
    click_tables,
    notes,
    write_tables,
)

MAX_BAND_MM_S = 100.0  # wider would smooth away the bleed's own low-speed damping


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "export",
        help="export a recording to CSV, or a fit to damper tables for vehicle simulation",
        description=(
            "REC.mcap --csv DIR: DIR/manifest.csv and one data CSV per test (docs/csv.md). "
            "FIT.json --damper-table DIR: per click, the fitted damper's force-velocity table "
            "as CSV and as a TeimOrbit damper property file (.dpr) (docs/ride.md)."
        ),
    )
    p.add_argument("source", type=Path, metavar="REC.mcap|FIT.json")
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--csv", type=Path, metavar="DIR", help="a recording to the CSV exchange")
    what.add_argument(
        "--damper-table", type=Path, metavar="DIR", help="a fit to force-velocity tables"
    )
    p.add_argument(
        "--clicks",
        metavar="LIST",
        help="--damper-table: click settings (default: the fitted ones; others by the trend)",
    )
    p.add_argument(
        "--adjuster",
        metavar="NAME",
        help="--damper-table of a damper with several adjusters: only this one's tables "
        "(default: every adjuster's, the others held at the sweep's base; docs/adjusters.md)",
    )
    p.add_argument(
        "--velocities-mm-s",
        metavar="LIST",
        help="--damper-table: speeds of the grid, both directions (default: 2.5 to 1000 mm/s; "
        "with --units imperial 0.1 to 40 in/s in round steps)",
    )
    p.add_argument(
        "--within-measured",
        action="store_true",
        help="--damper-table: stop each table at the velocities its recording reached "
        "(default: the whole grid, rows beyond marked measured = 0 in the CSV)",
    )
    p.add_argument(
        "--friction-band-mm-s",
        type=float,
        metavar="W",
        help="--damper-table: smooth the friction's step over ±W mm/s (e.g. 25), for "
        "vehicle-simulation solvers (default: the fitted model's own, 35 N within 2.5 mm/s)",
    )
    p.add_argument(
        "--units",
        choices=tuple(UNITS),
        default="si",
        help="--damper-table: mm/s and N, or in/s and lbf (--csv is always SI, as its "
        "column names say)",
    )
    add_force(p, "files already in DIR")
    p.set_defaults(func=_export)


def _export(args: argparse.Namespace) -> int:
    if args.csv is not None:
        for flag in ("clicks", "adjuster", "velocities_mm_s", "friction_band_mm_s"):
            if getattr(args, flag) is not None:
                raise ConfigError(f"--{flag.replace('_', '-')} goes with --damper-table")
        if args.within_measured:
            raise ConfigError("--within-measured goes with --damper-table")
        if args.units != "si":  # the exchange format import reads: its columns name SI units
            raise ConfigError(
                "--csv writes SI units (time_s, force_N, ...); --units goes with --damper-table"
            )
        require_recording(args.source, "a fit goes with --damper-table")
        rec = open_recording(args.source).require_recording()
        loss = rec.loss_note()
        if loss:  # a cut-off or damaged recording: what the export leaves out, said
            print(f"shockdyno export: warning: {args.source}: {loss}", file=sys.stderr)
        files = export_csv(rec, args.csv, force=args.force, velocity=_velocity)
        print(
            f"exported {len(files) - 1} tests to {args.csv} ({files[0].name} lists them), "
            "in SI units as the column names say"
        )
        return 0
    return _damper_table(args)


def _velocity(t: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """dx/dt as the analysis takes it (fit/prepare.py): the exported column is the velocity
    a fit or a click chart of these samples uses."""
    return differentiate(t, x)[0]


def _load_fit(path: Path) -> FitResult:
    try:
        recording = starts_as_mcap(path)
    except FileNotFoundError:
        raise ConfigError(f"fit file not found: {path}") from None
    except OSError as exc:
        raise ConfigError(f"cannot read {path} ({exc.strerror})") from None
    if recording:
        raise ConfigError(
            f"{path} is an MCAP recording; --damper-table takes a fit JSON "
            "(shockdyno fit REC.mcap --json FIT.json)"
        )
    return FitResult.load(path)


def _check_tables(tables: list[ClickTable], source: Path) -> None:
    """Refuse a damper no dyno measures (issue 46.11: a fit with a gas pressure of 1e300 Pa
    was written out as a table of 1.5e296 N): every force finite and within MAX_FORCE_N,
    the bound a recording's forces are held to (fit/file.py)."""
    for t in tables:
        forces = np.append(np.asarray(t.force_n, dtype=float), t.gas_force_n)
        worst = float(np.max(np.abs(forces))) if np.all(np.isfinite(forces)) else math.inf
        if worst > MAX_FORCE_N:
            raise ConfigError(
                f"{source}: the fitted damper at {t.clicks} clicks gives {worst:.3g} N, beyond "
                f"any damper dyno's {MAX_FORCE_N:.0e} N; not written (is the fit from this "
                "project, unedited?)"
            )


def _said(t: ClickTable) -> str:
    """A table on the terminal: 'clicks 12', or 'compression 12 clicks (rebound at 10)'."""
    return t.label if t.adjuster else f"clicks {t.clicks}"


def _damper_table(args: argparse.Namespace) -> int:
    out: Path = args.damper_table
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--damper-table {out} is a file, not a directory")
    fit = _load_fit(args.source)
    clicks = None if args.clicks is None else parse_ints(args.clicks, "--clicks")
    speeds: list[float] = []
    if args.velocities_mm_s is not None:
        speeds = [v * 1e-3 for v in parse_floats(args.velocities_mm_s, "--velocities-mm-s")]
        if any(not 0 < abs(v) <= 20 for v in speeds):
            raise ConfigError("--velocities-mm-s: speeds must be non-zero and at most 20000")
    elif args.units == "imperial":
        speeds = list(IMPERIAL_SPEEDS_M_S)
    band = args.friction_band_mm_s
    if band is not None and not (math.isfinite(band) and 0 < band <= MAX_BAND_MM_S):
        raise ConfigError(
            f"--friction-band-mm-s must be > 0 and at most {MAX_BAND_MM_S:g}, got {band:g}"
        )
    names = fit.adjuster_names()  # a damper with several: a table set per adjuster's line
    chosen = getattr(args, "adjuster", None)
    if chosen is not None and chosen not in names:
        raise ConfigError(
            f"--adjuster {chosen}: the fit's adjusters are {', '.join(names) or 'none (one rod)'}"
        )
    if names and clicks is not None and chosen is None:
        raise ConfigError(
            f"--clicks: the fit has adjusters {', '.join(names)}; name one with --adjuster"
        )
    tables = []
    for name in [chosen] if chosen else names or [""]:
        view = fit.for_adjuster(name) if name else fit
        made = click_tables(
            view,
            clicks,
            speeds,
            within_measured=args.within_measured,
            friction_band_m_s=None if band is None else band * 1e-3,
        )
        at = adjusters.base([c.adjusters for c in fit.clicks if c.adjusters]) if name else {}
        tables += [replace(t, adjuster=name, held=adjusters.held(name, at)) for t in made]
    _check_tables(tables, args.source)
    if out.is_dir():  # every target refused before anything is written
        for t in tables:
            for suffix in (".csv", ".dpr"):
                check_output(
                    out / f"{t.stem}{suffix}",
                    force=args.force,
                    inputs=[args.source],
                    flag="--damper-table",
                )
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"--damper-table: cannot create {out} ({exc.strerror})") from None
    spec_name = fit.spec().name
    files = write_tables(tables, out, UNITS[args.units], spec_name, __version__)
    trend = [t.clicks for t in tables if t.source == "trend"]
    note = f" ({len(trend)} from the fit's trend)" if trend else ""
    print(
        f"wrote {len(files)} files to {out}: force-velocity tables (CSV) and damper property "
        f"files (.dpr) for {len(tables)} click settings{note}, in {args.units} units"
    )
    units = UNITS[args.units]
    for t in tables:
        if t.measured_m_s is None:
            print(f"  {_said(t)}: {notes(t, units)[0]}")
            continue
        rebound, compression = (x / units.m_s_per_unit for x in t.measured_m_s)
        beyond = int(np.count_nonzero(~t.measured)) if t.measured is not None else 0
        print(
            f"  {_said(t)}: measured to {rebound:.4g} / {compression:.4g} {units.velocity} "
            f"(rebound / compression){' from the fitted clicks either side' * (t.source != 'fit')}"
            f"; {beyond} rows beyond, the model extrapolated"
        )
    if any(t.measured is not None and not t.measured.all() for t in tables):
        print("  rows beyond are marked measured = 0 in the CSV; --within-measured stops there")
    if band is not None:
        print(f"  the friction smoothed over {band:g} mm/s in every table (--friction-band-mm-s)")
    return 0
