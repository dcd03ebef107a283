"""`shockdyno diagnose REC.mcap [--fit FIT.json] [--terms LIST] --json DIAG.json [--report DIR]`."""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

from rich.console import Console
from rich.table import Table

from shockdyno import units as units_mod
from shockdyno.atomic import staged_dir
from shockdyno.commands.args import Subparsers, add_seed, add_spec, add_term_list, require_recording
from shockdyno.commands.history import add_history_argument, keep
from shockdyno.diagnose.file import diagnose_file, parse_candidates
from shockdyno.diagnose.workers import usable_cores
from shockdyno.errors import ConfigError
from shockdyno.history import record_diagnosis
from shockdyno.model import load_spec
from shockdyno.model.spec import spec_line
from shockdyno.outputs import check_output, check_report_dir, write_output
from shockdyno.progress import StageProgress, table_console
from shockdyno.record.identity import add_allow_argument
from shockdyno.record.layout import set_paths
from shockdyno.report.documents import DiagnosisDoc, Finding, diagnosis_text
from shockdyno.report.findings_table import finding_cells


def register(sub: Subparsers) -> None:
    p = sub.add_parser(
        "diagnose",
        help="find where model and recording differ, name the missing physics, refit",
        description=(
            "Split the fitted model's residual into structure and noise, locate the "
            "structure, try each physics term of the library (refitted with the globals "
            "and areas), claim a term only when a cycle-bootstrap likelihood ratio and "
            "held-out prediction agree, and refit with it. DIAG.json is documented in "
            "docs/diagnose.md."
        ),
    )
    p.add_argument("recording", metavar="REC.mcap", help="recording to diagnose")
    p.add_argument(
        "--json",
        required=True,
        metavar="DIAG.json",
        help="where to write the diagnosis ('-': standard output)",
    )
    p.add_argument(
        "--fit", metavar="FIT.json", help="start from this fit's model (default: fit the paper's)"
    )
    p.add_argument(
        "--terms",
        default="all",
        metavar="LIST",
        help="candidate terms, comma-separated, or 'all' (the whole library, listed below)",
    )
    add_term_list(p)
    p.add_argument("--report", metavar="DIR", help="also write figures and index.html here")
    add_spec(p, "without --fit")
    p.add_argument("--alpha", type=float, default=0.01, help="significance level of a claim")
    add_seed(p, "the bootstrap")
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="processes for the search's candidate refits (default: this machine's usable "
        "cores); the diagnosis is the same with any number",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="overwrite an existing DIAG.json or --report page",
    )
    add_allow_argument(p, "a --fit")
    units_mod.add_argument(p, "the terminal text, table and --report page")
    add_history_argument(p)
    p.set_defaults(func=run_diagnose)


def _summary(findings: tuple[Finding, ...], units: units_mod.Units = units_mod.SI) -> Table:
    table = Table(title="Candidate physics (refitted with globals and areas)")
    effect = f"peak effect {units.force_label}"
    for name in ("round", "physics", "claimed", "p", "held-out gain", effect, "note"):
        table.add_column(name, justify="left" if name in ("physics", "note") else "right")
    for f in findings:  # the page's cells, its parameters left to the page
        rnd, physics, claimed, p, gain, peak, _, alike, why_not = finding_cells(f, units)
        note = why_not or (f"alike: {alike}" if alike else "")
        table.add_row(rnd, physics, "[bold green]yes[/]" if claimed else "", p, gain, peak, note)
    return table


def _nan(x: float | None) -> float:
    return math.nan if x is None else x


def run_diagnose(args: argparse.Namespace) -> int:
    inputs, out, workers = _checked_arguments(args)
    with StageProgress("diagnose") as progress:
        d, doc = diagnose_file(
            Path(args.recording),
            fit_path=args.fit,
            spec=args.spec,
            alpha=args.alpha,
            seed=args.seed,
            terms=args.terms,
            allow_other_recording=args.allow_other_recording,
            progress=progress,
            warn=lambda line: print(line, file=sys.stderr),
            workers=workers,
        )
    if args.report:  # DIAG.json names the figures drawn below, for `report --diagnose`
        # Imported when used: +620 ms CPU at start-up (matplotlib).
        from shockdyno.diagnose.report import figure_paths

        figures = figure_paths(Path(args.report), args.json)
        # the units they are drawn in: report says so if its page's differ
        doc = replace(doc, info=replace(doc.info, figures=figures, figures_units=args.units))
    text = diagnosis_text(doc)
    # Written before the figures are drawn: a plotting failure must not lose the diagnosis.
    write_output(args.json, text, force=args.force, inputs=inputs)
    keep(
        args,
        lambda db: record_diagnosis(
            db, Path(args.recording), doc, args.json, args.alpha, args.seed, args.terms
        ),
        "the diagnosis",
    )
    shown = table_console(stderr=out is None)
    units = units_mod.get(args.units)
    _print_diagnosis(shown, doc, units)
    if args.report:
        from shockdyno.diagnose.report import write_report  # +620 ms at start-up, as above

        with staged_dir(Path(args.report)) as folder:  # whole, or not at all
            write_report(d, doc, folder, units)
        shown.print(f"report: {Path(args.report) / 'index.html'}")
    if out is not None:
        shown.print(f"wrote {out} in {d.wall_s:.1f} s")
    return 0


def _checked_arguments(args: argparse.Namespace) -> tuple[list[str | Path], Path | None, int]:
    """The command's inputs (never written over), its output (None: standard output) and
    its worker count; a bad option, spec or term list fails here, before any reading."""
    require_recording(args.recording)
    inputs = [
        *set_paths(Path(args.recording)),
        *([args.fit] if args.fit else []),
        *([args.spec] if args.spec else []),
    ]
    out = check_output(args.json, force=args.force, inputs=inputs)
    if args.report:
        check_report_dir(Path(args.report), inputs, args.force)
    if not 0 < args.alpha < 1:
        raise ConfigError(f"--alpha must be between 0 and 1, got {args.alpha}")
    if args.fit is None:
        load_spec(args.spec)  # a bad spec fails before reading the recording
    parse_candidates(args.terms)  # a bad list fails before anything is read
    workers = usable_cores() if args.workers is None else args.workers
    if workers < 1:
        raise ConfigError(f"--workers must be at least 1, got {workers}")
    return inputs, out, workers


def _print_diagnosis(shown: Console, doc: DiagnosisDoc, units: units_mod.Units) -> None:
    """The terminal's diagnosis: the spec used, the mismatch and its noise, the candidates'
    table (when the mismatch is significant) and the verdict; short tests warned of on
    standard error."""
    used = doc.info.spec
    assert used is not None  # diagnose_file says which spec
    via = f", the base spec of {used.from_fit}" if used.from_fit is not None else ""
    shown.print(spec_line(vars(used)) + via, soft_wrap=True, highlight=False, markup=False)
    m = doc.mismatch
    if doc.short_tests:  # a warning, not an error: the rest of the diagnosis stands
        n = len(doc.short_tests)
        print(
            f"warning: {n} test{'s' * (n > 1)} of fewer than two whole cycles: nothing "
            "claimed from them (no cycle-to-cycle noise to test against)",
            file=sys.stderr,
        )
    fl = units.force_label
    if not m.tested:
        shown.print("mismatch: not tested (no test has two whole cycles)")
    else:
        shown.print(
            f"mismatch: {'[bold red]significant[/]' if m.significant else 'none beyond noise'} "
            f"(p = {_nan(m.p_value):.3g}); structure "
            f"{units.force(_nan(m.structured_rms_n)):.3g} {fl} "
            f"RMS, noise {units.force(_nan(m.noise_floor_n)):.3g} {fl}, about "
            f"{_nan(m.effective_values):.0f} independent values"
            + (
                f"; {m.lone_cells} lone cycle-phase cell{'s' if m.lone_cells != 1 else ''} left out"
                if m.lone_cells
                else ""
            )
        )
    if m.significant:
        shown.print(_summary(doc.findings, units))
    text = (doc.verdict.text_imperial if units.imperial else None) or doc.verdict.text
    shown.print(f"[bold]verdict:[/] {text}")
