"""`shockdyno compare A B [C ...] [--fit FIT.json ...] -o DIR [--json FILE]`."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from shockdyno import units as units_mod
from shockdyno.atomic import staged_dir
from shockdyno.commands.args import Subparsers, add_gas_arguments
from shockdyno.errors import ConfigError
from shockdyno.outputs import check_output, check_report_dir, write_output
from shockdyno.report.gas import parse_given, warnings
from shockdyno.units import Units

if TYPE_CHECKING:
    from shockdyno.compare.table import Row


def register(sub: Subparsers) -> None:
    p = sub.add_parser(
        "compare",
        help="recordings and fits side by side: overlays, click charts, a difference table",
        description=(
            "Compare recordings (.mcap: real, imported or simulated; measured) and fits "
            "(FIT.json: the model), any mix, against the first input: peak-force curves and "
            "loops overlaid, click charts side by side, and a difference table at the "
            "standard velocities judged against the scatter the recordings show. Writes "
            "DIR/index.html with PNGs beside it (offline). Documented in docs/compare.md."
        ),
    )
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="recordings or fits; the first is A")
    p.add_argument(
        "--fit", action="append", default=[], metavar="FIT.json",
        help="a fit to compare as well (repeatable); also accepted as an INPUT",
    )  # fmt: skip
    p.add_argument(
        "--label", action="append", default=[], metavar="NAME=TEXT",
        help="name an input on the page, NAME being its path or file stem (default: the stem)",
    )  # fmt: skip
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="page directory")
    p.add_argument("--json", metavar="FILE", help="write the difference table (SI) here; - stdout")
    p.add_argument("--title", default="Comparison", help="page title")
    units_mod.add_argument(p, "the page's tables and plots")
    p.add_argument(
        "--raw-force",
        action="store_true",
        help="compare the force as measured (default: damping force, the gas force removed)",
    )
    add_gas_arguments(p)
    p.add_argument(
        "--adjuster",
        metavar="NAME",
        help="inputs of a damper with several adjusters: compare along this one, the others "
        "at each sweep's base (docs/adjusters.md)",
    )
    p.add_argument("--force", action="store_true", help="replace an existing page or --json file")
    p.set_defaults(func=run_compare)


def run_compare(args: argparse.Namespace) -> int:
    # Imported when run, not at start-up: +470 ms CPU there (the page's matplotlib), the
    # inputs and table +10 and +13 ms (measured).
    from shockdyno.compare.inputs import default_labels, load_input
    from shockdyno.compare.page import render
    from shockdyno.compare.table import difference_rows, shared_settings, to_json

    units = units_mod.get(args.units)
    paths = [*args.inputs, *args.fit]
    _check_distinct(paths)
    out = Path(args.output)
    check_report_dir(out, paths, args.force, flag="-o")
    if args.json:
        check_output(args.json, force=args.force, inputs=paths)
    labels = default_labels(paths, args.label)
    flags = ["input"] * len(args.inputs) + ["--fit"] * len(args.fit)
    given = parse_given(args.gas_force_n) if args.gas_force_n else None
    inputs = [
        load_input(
            Path(p),
            label,
            units.standard_velocities_m_s,
            flag,
            args.raw_force,
            given,
            args.spec,
            args.adjuster,
        )
        for p, label, flag in zip(paths, labels, flags, strict=True)
    ]
    for i in inputs:  # a cut-off recording, a refused or rate-dependent gas force: said first
        if i.loss:
            print(f"compare: warning: {i.label}: {i.path}: {i.loss}", file=sys.stderr)
        for text in warnings(i.gas, units):
            print(f"compare: warning: {i.label}: {text}", file=sys.stderr)
    if not shared_settings(inputs):
        have = "; ".join(
            f"{i.label}: {', '.join(f'{c}/{g}' for c, g in i.settings) or 'none'}" for i in inputs
        )
        raise ConfigError(
            f"the inputs share no click setting with {inputs[0].label} (clicks/gas: {have})"
        )
    rows = difference_rows(inputs)
    with staged_dir(out) as folder:  # the page appears whole, or not at all
        render(inputs, rows, folder, units, args.title)
    index = out / "index.html"
    if args.json:
        text = json.dumps(to_json(inputs, rows), indent=2, allow_nan=False) + "\n"
        write_output(args.json, text, force=args.force, inputs=paths)
    _say_verdict(rows, units)
    # With --json - the table owns standard output.
    print(f"compare: {index}", file=sys.stderr if args.json == "-" else sys.stdout)
    return 0


def _check_distinct(paths: list[str]) -> None:
    """Two or more inputs, no file given twice (under two spellings either)."""
    if len(paths) < 2:
        raise ConfigError("give two or more inputs to compare (recordings or fits)")
    seen: dict[Path, str] = {}
    for p in paths:
        again = seen.setdefault(Path(p).resolve(), p)
        if again != p or paths.count(p) > 1:
            raise ConfigError(f"{p}: given twice (as {again}); compare needs different inputs")


def _say_verdict(rows: list[Row], units: Units) -> None:
    """On standard error: the values that differ beyond the scatter, largest first, or
    that none do (and how many could not be judged)."""
    # here: as in run_compare (compare.table +13 ms)
    from shockdyno.compare.table import differences

    found = [r for r in rows if r.verdict == "difference"]
    if found:
        lines = differences(rows, units)
        print(
            f"compare: {len(found)} of {len(rows)} values differ beyond the scatter, in "
            f"{len(lines)} setting{'s' * (len(lines) > 1)} and direction"
            f"{'s' * (len(lines) > 1)} (largest first):",
            file=sys.stderr,
        )
        for line in lines:
            print(f"  {line}", file=sys.stderr)
    else:
        unjudged = sum(r.verdict == "not judged" for r in rows)
        print(
            "compare: no difference beyond the scatter"
            + (
                f"; {unjudged} of {len(rows)} values not judged (extrapolated, or two fits "
                "with no scatter to judge against: see the table's differences)"
                if unjudged
                else ""
            ),
            file=sys.stderr,
        )
