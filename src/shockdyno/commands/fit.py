"""`shockdyno fit REC.mcap --json FIT.json [--report DIR] [--optimizer ga|fast] ...`."""

from __future__ import annotations

import argparse
import csv
import functools
import io
import math
import sys
from collections.abc import Callable
from pathlib import Path

from rich.console import Console
from rich.table import Table

from shockdyno import units as units_mod
from shockdyno.atomic import staged_dir, write_text_atomic
from shockdyno.commands.args import (
    Subparsers,
    add_force,
    add_seed,
    add_spec,
    add_term_list,
    require_recording,
)
from shockdyno.commands.history import add_history_argument, keep
from shockdyno.fit import forces
from shockdyno.fit.display import Shown, bound_hit, bound_text, globals_rows, shown
from shockdyno.fit.file import fit_file, result_json
from shockdyno.fit.prepare import FITTED_ANYWAY
from shockdyno.fit.result import FitResult
from shockdyno.fit.terms import parse_terms
from shockdyno.fit.validate import table4_rows, table4_table
from shockdyno.history import record_fit
from shockdyno.model import load_spec
from shockdyno.model.params import Estimate
from shockdyno.model.spec import spec_line, spec_used
from shockdyno.model.terms import LIBRARY
from shockdyno.outputs import check_output, check_report_dir, write_output
from shockdyno.progress import StageProgress, table_console
from shockdyno.record import open_recording
from shockdyno.record.layout import set_paths
from shockdyno.record.types import TestData
from shockdyno.report.temperature import add_argument as add_reference_temperature
from shockdyno.report.temperature import reference_c
from shockdyno.units import SI, Units


def register(sub: Subparsers) -> None:
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
    p.add_argument(
        "--json", required=True, metavar="FIT.json", help="where to write the result (- for stdout)"
    )
    add_force(p, "an existing --json file or --report page")
    p.add_argument(
        "--report",
        metavar="DIR",
        help="also write DIR/index.html: the report page with the fit (figures, Table 4, "
        "click chart), and table4.csv beside it",
    )
    add_reference_temperature(p)
    p.add_argument(
        "--raw-force",
        action="store_true",
        help="with --report: click chart and peaks in raw force, gas force included "
        "(default: damping force, gas force removed; docs/report.md)",
    )
    p.add_argument(
        "--optimizer",
        choices=("fast", "ga"),
        default="fast",
        help="per-click optimiser: fast (default) or the paper's GA (Table 1; slower)",
    )
    add_spec(p)
    add_seed(p, "the GA (default 0)")
    p.add_argument(
        "--terms",
        default="sensor_lag",
        metavar="LIST",
        help=(
            f"physics terms fitted with the globals, comma-separated: {', '.join(LIBRARY)}; "
            "term.param frees a parameter the term holds; none: the paper's model alone "
            "(default: sensor_lag, the channel delay)"
        ),
    )
    units_mod.add_argument(p, "the terminal tables and the --report page")
    add_history_argument(p)
    add_term_list(p)
    p.set_defaults(func=run_fit)


def terms_table(terms: dict[str, dict[str, Estimate]], units: Units = SI) -> Table:
    """Fitted term parameters: value ± σ in display units; held ones, and those pressed
    against a bound ("at lower bound (0 ms)" in place of the value), marked."""
    table = Table(title="Physics terms (±1σ)")
    for name in ("term", "parameter", "value", "±1σ", "unit", "note"):
        table.add_column(name, justify="left" if name in ("term", "parameter", "note") else "right")
    for term, params in terms.items():
        declared = {p.name: p for p in getattr(LIBRARY.get(term), "PARAMS", ())}
        for k, est in params.items():
            param = declared.get(k)
            show = shown(est.unit, units, est.value if param is None else param.nominal)
            value = show.text(est.value)
            note = "held" if est.fixed else ""
            if est.at_bound and not est.fixed:
                side = "" if param is None else bound_hit(est.value, param.lo, param.hi)
                if side and param is not None:
                    value = bound_text(side, param.lo if side == "lower" else param.hi, show)
                else:
                    note = "at a bound"
                    value = "0" if abs(est.value) <= AT_ZERO else value  # not 1.7e-28
            sd = "" if not math.isfinite(est.sd) else f"{show.spread(est.sd):.3g}"
            table.add_row(term, k, value, sd, show.label, note)
    return table


AT_ZERO = 1e-12  # SI: an optimiser hugging a bound of 0 leaves 1.7e-28 there, not data


def _area(value: float, sd: float, show: Shown) -> str:
    """An area with its 1-σ uncertainty in percent (compact for narrow terminals); a
    bleed closed to the optimiser's floor (1e-24 m²) reads 0."""
    if abs(value) <= AT_ZERO:
        return "0" if not math.isfinite(sd) or sd <= AT_ZERO else f"0 ±{show.spread(sd):.1g}"
    text = f"{show.value(value):.4g}"
    if not math.isfinite(sd):
        return text + " ±?"
    if value > 0:
        return text + f" ±{100 * sd / value:.2g}%"
    return text + f" ±{show.spread(sd):.1g}"


def _clicks_table(result: FitResult, units: Units = SI) -> Table:
    show = shown("m²", units)
    table = Table(title=f"Bleed areas per click ({show.label}, ±1σ)")
    names = result.adjuster_names()  # a damper with several: a column each, not "clicks"
    for name in (*(names or ["clicks"]), "gas", "A_bc", "A_bt", "A_b Talbott", "identifiable"):
        table.add_column(name, justify="right")
    for c in result.clicks:
        ident = {(True, True): "both", (True, False): "A_bc", (False, True): "A_bt"}
        table.add_row(
            *([str(c.adjusters.get(n, "")) for n in names] or [str(c.clicks)]),
            str(c.gas_clicks),
            _area(c.a_bc_m2, c.a_bc_sd_m2, show),
            _area(c.a_bt_m2, c.a_bt_sd_m2, show),
            _area(c.a_b_talbott_m2, c.a_b_talbott_sd_m2, show),
            ident.get((c.identifiable_bc, c.identifiable_bt), "neither"),
        )
    return table


def _globals_table(result: FitResult, units: Units = SI) -> Table:
    header, rows = globals_rows(result, units)
    table = Table(title="Calibrated globals (±1σ)")
    for name in header:
        table.add_column(name, justify="left" if name in ("parameter", "unit") else "right")
    for row in rows:
        table.add_row(*row)
    return table


def run_fit(args: argparse.Namespace) -> int:
    require_recording(args.recording)
    reference = reference_c(args.reference_temperature_c)
    inputs = [*set_paths(Path(args.recording)), *([args.spec] if args.spec else [])]
    out = check_output(args.json, force=args.force, inputs=inputs)
    # The model's forces the report draws, beside the JSON (fit/forces.py; none on stdout)
    sidecar = None if out is None else forces.sidecar_path(out)
    if sidecar is not None:
        check_output(sidecar, force=args.force, inputs=inputs, flag="--json's model forces")
    if args.report:
        check_report_dir(Path(args.report), inputs, args.force)
    load_spec(args.spec)  # a bad spec or term list fails now, not after reading
    parse_terms(args.terms)
    console = Console(stderr=True)
    with StageProgress("fit", console) as progress:
        result, tests = fit_file(
            Path(args.recording),
            spec=args.spec,
            optimizer=args.optimizer,
            seed=args.seed,
            terms=args.terms,
            progress=progress,
            warn=lambda line: print(line, file=sys.stderr),
        )
    text = result_json(result)  # a result that cannot be written fails before anything is
    # With --json -, stdout carries only the JSON; the human summary goes to stderr.
    human = table_console(stderr=out is None)
    # The JSON keeps the spec as `spec_path`; the terminal says which one it was.
    human.print(spec_line(spec_used(args.spec)), soft_wrap=True, highlight=False, markup=False)
    units = units_mod.get(args.units)
    human.print(_globals_table(result, units))
    if result.terms:
        human.print(terms_table(result.terms, units))
    human.print(_clicks_table(result, units))
    human.print(table4_table(result))
    write_output(args.json, text, force=args.force, inputs=inputs)
    wrote = "stdout" if out is None else str(out)
    if sidecar is not None and result.saved is not None:
        forces.write(sidecar, result.saved, text)
        # Said: a FIT.json copied or moved without it is computed again by each report.
        wrote += f" and the model's forces {sidecar.name} beside it"
    keep(args, lambda db: record_fit(db, Path(args.recording), result, args.json, tests), "the fit")
    info = result.info
    ident = sum(c.identifiable_bc + c.identifiable_bt for c in result.clicks)
    say = functools.partial(print, file=sys.stderr if out is None else sys.stdout)
    say(
        f"fitted {len(result.clicks)} click settings from {info.n_tests} tests in "
        f"{info.wall_s or 0:.1f} s ({info.model_evaluations} model evaluations); "
        f"{ident} of {2 * len(result.clicks)} areas identifiable; "
        f"wrote {wrote}"
    )
    for note in info.skipped or ():
        say(f"note: {note}" if note.endswith(FITTED_ANYWAY) else f"skipped {note}")
    if args.report:
        _write_report(args, result, tests, reference, console, say)
    return 0


def _write_report(
    args: argparse.Namespace,
    result: FitResult,
    tests: list[TestData],
    reference_temperature_c: float,
    console: Console,
    say: Callable[[str], None],
) -> None:
    """--report DIR: the report page with the fit, and table4.csv beside it."""
    # Imported when used: +460 ms CPU at start-up (matplotlib).
    from shockdyno.report.build import build_report

    report = Path(args.report)
    rec = open_recording(args.recording)
    header, rows = table4_rows(result)
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows([header, *rows])
    # The page, its figures and table4.csv appear whole, or not at all.
    with console.status("fit: writing the report") as status, staged_dir(report) as folder:
        build_report(
            tests,
            folder,
            title=f"{rec.metadata.get('damper_id') or Path(args.recording).stem}: fit report",
            metadata={"recording": str(args.recording), **rec.metadata},
            fit=result,
            progress=lambda stage: status.update(f"fit report: {stage}"),
            reference_temperature_c=reference_temperature_c,
            units=units_mod.get(args.units),
            raw_force=args.raw_force,
        )
        write_text_atomic(folder / "table4.csv", buf.getvalue())
    say(f"report: {report / 'index.html'}")
    say(f"table: Table 4 analogue: {report / 'table4.csv'}")
