"""`shockdyno fit REC.mcap --json FIT.json [--report DIR] [--optimizer ga|fast] ...`."""

from __future__ import annotations

import argparse
import csv
import io
import math
from pathlib import Path
from typing import Any

from shockdyno.errors import ConfigError


def register(sub: Any) -> None:
    p = sub.add_parser(
        "fit",
        help="fit globals and bleed areas per click to a recording; validate (Table 4)",
        description=(
            "Calibrate the damper's global parameters over every test of a recording, fit "
            "the bleed areas per click (proposed: A_bc, A_bt; Talbott: A_b) by eq. 8, trend "
            "them against clicks and print the per-frequency error table. The JSON written "
            "is documented in docs/fit.md."
        ),
    )
    p.add_argument("recording", metavar="REC.mcap", help="recording to fit")
    p.add_argument("--json", required=True, metavar="FIT.json", help="where to write the result")
    p.add_argument(
        "--report",
        metavar="DIR",
        help="also write the figures (PNG) and the Table 4 analogue (table4.csv) here",
    )
    p.add_argument(
        "--optimizer",
        choices=("fast", "ga"),
        default="fast",
        help="per-click optimiser: fast (default) or the paper's GA (Table 1; slower)",
    )
    p.add_argument(
        "--spec", metavar="PATH", help="base damper spec TOML (default: sim/ohlins-s46.toml)"
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the GA (default 0)")
    p.set_defaults(func=run_fit)


def _mm2(value: float, sd: float) -> str:
    """Area in mm² with its 1-σ uncertainty in percent (compact for narrow terminals)."""
    text = f"{value * 1e6:.4g}"
    if not math.isfinite(sd):
        return text + " ±?"
    if value > 0:
        return text + f" ±{100 * sd / value:.2g}%"
    return text + f" ±{sd * 1e6:.1g}"


def _clicks_table(result: Any) -> Any:
    from rich.table import Table

    table = Table(title="Bleed areas per click (mm², ±1σ)")
    for name in ("clicks", "gas", "A_bc", "A_bt", "A_b Talbott", "identifiable"):
        table.add_column(name, justify="right")
    for c in result.clicks:
        ident = {(True, True): "both", (True, False): "A_bc", (False, True): "A_bt"}
        table.add_row(
            str(c.clicks),
            str(c.gas_clicks),
            _mm2(c.a_bc_m2, c.a_bc_sd_m2),
            _mm2(c.a_bt_m2, c.a_bt_sd_m2),
            _mm2(c.a_b_talbott_m2, c.a_b_talbott_sd_m2),
            ident.get((c.identifiable_bc, c.identifiable_bt), "neither"),
        )
    return table


def _num(value: Any, scale: float = 1.0) -> str:
    return (
        f"{value * scale:.4g}" if isinstance(value, int | float) and math.isfinite(value) else "?"
    )


def _globals_table(result: Any) -> Any:
    """The calibrated globals (result.globals) beside the spec's values, and the force channel's
    delay; every key of result.globals is shown, whatever parameters the fit calibrates."""
    from rich.table import Table

    cal = result.info.get("calibration", {})
    nominal, sd = cal.get("globals_nominal", {}), cal.get("globals_sd", {})
    table = Table(title="Calibrated globals (SI units, as named; ±1σ)")
    for name in ("parameter", "fitted", "±1σ", "spec", "change"):
        table.add_column(name, justify="left" if name == "parameter" else "right")
    for key, value in result.globals.items():
        base = nominal.get(key)
        change = "?"
        if isinstance(base, int | float) and base != 0 and math.isfinite(base):
            change = f"{100 * (value / base - 1):+.1f}%"
        table.add_row(key, _num(value), _num(sd.get(key)), _num(base), change)
    if "force_delay_s" in cal:
        delay, delay_sd = cal["force_delay_s"], cal.get("force_delay_sd_s")
        table.add_row("force delay, ms", _num(delay, 1e3), _num(delay_sd, 1e3), "0", "")
    return table


def run_fit(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from shockdyno.fit.sweep import fit_sweep
    from shockdyno.fit.validate import table4_table

    out = Path(args.json)
    if not out.parent.is_dir():
        raise ConfigError(f"--json: directory {out.parent} does not exist")
    if out.is_dir():
        raise ConfigError(f"--json: {out} is a directory")
    from shockdyno.model import load_spec
    from shockdyno.record import open_recording

    load_spec(args.spec)  # a bad spec fails now, not after reading the recording
    tests = open_recording(args.recording).load_all()
    console = Console(stderr=True)
    with Progress(
        TextColumn("[bold]fit[/] {task.description}"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    ) as bar:
        task = bar.add_task("prepare", total=1.0)

        def progress(stage: str, fraction: float) -> None:
            bar.update(task, description=stage, completed=fraction)

        result = fit_sweep(
            tests, spec_path=args.spec, optimizer=args.optimizer, seed=args.seed, progress=progress
        )
    result.save(out)
    Console().print(_globals_table(result))
    Console().print(_clicks_table(result))
    Console().print(table4_table(result))
    info = result.info
    ident = sum(c.identifiable_bc + c.identifiable_bt for c in result.clicks)
    print(
        f"fitted {len(result.clicks)} click settings from {info['n_tests']} tests in "
        f"{info['wall_s']:.1f} s ({info['model_evaluations']} model evaluations); "
        f"{ident} of {2 * len(result.clicks)} areas identifiable; wrote {out}"
    )
    for note in info.get("skipped", []):
        print(f"skipped {note}")
    if args.report:
        from shockdyno.fit.plots import fit_figures
        from shockdyno.fit.validate import table4_rows
        from shockdyno.record.atomic import write_text_atomic

        report = Path(args.report)
        report.mkdir(parents=True, exist_ok=True)
        figures = fit_figures(result, tests, report)
        for title, path in figures:
            print(f"figure: {title}: {path}")
        header, rows = table4_rows(result)
        text = io.StringIO()
        csv.writer(text, lineterminator="\n").writerows([header, *rows])
        table = report / "table4.csv"
        write_text_atomic(table, text.getvalue())
        print(f"table: Table 4 analogue: {table}")
    return 0
