"""`shockdyno history [DAMPER] [--list] [--plot PNG] [--json PATH]`: how a damper changed.

Also the one way the other commands reach the history: `add_history_argument` for
`--history PATH` / `--no-history`, and `keep` to add a result, saying so in one line and
never failing the command whose result is already written.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

from rich.table import Table

from shockdyno.commands.args import Subparsers
from shockdyno.errors import ConfigError
from shockdyno.history import DEFAULT, ENV, default_path, store
from shockdyno.history.store import RecordingEntry, Visit
from shockdyno.history.view import (
    CHANGED,
    K_SIGMA,
    MIN_SHARE,
    UNJUDGED,
    diagnosis_text,
    gas_text,
    plot,
    series,
)
from shockdyno.outputs import check_output, write_output
from shockdyno.progress import table_console


def register(sub: Subparsers) -> None:
    p = sub.add_parser(
        "history",
        help="how a damper changed: its recordings, fitted areas, parameters, diagnoses",
        description=(
            "Every recording of DAMPER (its --damper-id) that fit, diagnose or batch added to "
            "the history database, oldest first: date, operator, gas force, E_t, the physics "
            "diagnosed; the bleed areas per click and the fitted parameters side by side; "
            "what changed beyond its uncertainty from the first to the last. Documented in "
            "docs/history.md."
        ),
    )
    p.add_argument("damper", nargs="?", metavar="DAMPER", help="damper id (see --list)")
    p.add_argument("--list", action="store_true", help="the dampers in the history")
    p.add_argument("--plot", metavar="PNG", help="also plot the quantities against the date")
    p.add_argument("--json", metavar="PATH", help="the damper's history as JSON (- stdout)")
    p.add_argument("--force", action="store_true", help="overwrite an existing --plot/--json")
    add_history_argument(p, reading=True)
    p.set_defaults(func=run_history)


def add_history_argument(p: argparse.ArgumentParser, reading: bool = False) -> None:
    p.add_argument(
        "--history",
        metavar="DB",
        type=Path,
        help=f"the history database (default ${ENV}, else {DEFAULT})",
    )
    if not reading:
        p.add_argument(
            "--no-history",
            action="store_true",
            help="do not add this result to the history database",
        )


def database(args: argparse.Namespace) -> Path:
    return Path(args.history) if args.history is not None else default_path()


def keep(args: argparse.Namespace, add: Callable[[Path], RecordingEntry], what: str) -> None:
    """Run `add(db)` unless --no-history; its result is written already, so a history that
    cannot take it is a warning line, not the command's failure."""
    if getattr(args, "no_history", False):
        return
    db = database(args)
    try:
        rec = add(db)
    except (ConfigError, OSError) as exc:
        print(f"warning: history not updated: {exc}", file=sys.stderr)
        return
    who = rec.damper_id or "no damper id"
    print(f"history: {what} of {rec.file} ({who}) kept in {db}", file=sys.stderr)


def run_history(args: argparse.Namespace) -> int:
    db = database(args)
    if not db.exists():
        raise ConfigError(
            f"no history at {db}: fit, diagnose and batch add to it (or name one: --history)"
        )
    if args.list or not args.damper:
        rows = store.dampers(db)
        if not args.list:
            named = [damper for damper, *_ in rows if damper] or ["S46-0421"]
            raise ConfigError(
                f"give a damper id, e.g. shockdyno history {named[0]} (--list lists them)"
            )
        print(f"{len(rows)} dampers in {db}:")
        for damper, n, first, last in rows:
            print(f"  {damper or '(no damper id)'}: {n} recordings, {first[:10]} to {last[:10]}")
        return 0
    for flag, out in (("--plot", args.plot), ("--json", args.json)):
        if out is not None:
            check_output(out, force=args.force, inputs=[db], flag=flag)
    visits, left_out = store.grown(store.visits(db, args.damper))
    if not visits:
        known = [d for d, *_ in store.dampers(db)]
        near = ", ".join(d or "(no damper id)" for d in known[:8]) or "none"
        raise ConfigError(f"no recording of damper {args.damper!r} in {db} (known: {near})")
    _print(args.damper, visits, db, args.json == "-")
    if left_out:
        print(
            f"({left_out} earlier reading{'s' * (left_out > 1)} of a recording that grew "
            "when its sweep was resumed not shown)",
            file=sys.stderr if args.json == "-" else sys.stdout,
        )
    if args.json is not None:
        doc = {"damper": args.damper, "database": str(db), "visits": [asdict(v) for v in visits]}
        write_output(args.json, json.dumps(doc, indent=2, allow_nan=False) + "\n",
                     force=args.force, inputs=[db], flag="--json")  # fmt: skip
    if args.plot is not None:
        plot(visits, series(visits), args.damper, Path(args.plot))
        print(f"plot: {args.plot}", file=sys.stderr if args.json == "-" else sys.stdout)
    return 0


def _print(damper: str, visits: list[Visit], db: Path, to_stderr: bool) -> None:
    console = table_console(stderr=to_stderr)
    console.print(f"history of damper {damper}: {len(visits)} recordings in {db}")
    table = Table(title="Recordings, oldest first")
    for name in ("#", "recorded (UTC)", "operator", "file", "clicks", "gas force", "E_t fit",
                 "terms", "diagnosed"):  # fmt: skip
        # a narrow terminal wraps a file name rather than cutting it to "s46-0421-rec…"
        right = name in ("#", "E_t fit")
        table.add_column(name, justify="right" if right else "left", overflow="fold")
    for k, v in enumerate(visits, 1):
        fit = v.latest("fit")
        table.add_row(
            str(k), v.recording.recorded_utc.replace("T", " ").rstrip("Z"),
            v.recording.operator or "–", Path(v.recording.file).name, v.recording.clicks,
            gas_text(v), "–" if fit is None or fit.e_t is None else f"{fit.e_t:.3g}",
            (fit.physics or "none") if fit else "–", diagnosis_text(v),
        )  # fmt: skip
    console.print(table)
    all_series = series(visits)
    values = Table(title="Fitted values per recording (±1σ)")
    values.add_column("quantity")
    values.add_column("unit")
    for k in range(len(visits)):
        values.add_column(f"#{k + 1}", justify="right")
    for s in all_series:
        if s.present:
            values.add_row(s.name, s.unit, *(s.shown(k) for k in range(len(visits))))
    console.print(values)
    verdicts = {s.name: c[2] for s in all_series if (c := s.change()) is not None}
    changed = [s for s in all_series if verdicts.get(s.name) == CHANGED]
    unjudged = [s for s in all_series if verdicts.get(s.name) == UNJUDGED]
    if len(visits) < 2:
        console.print("one recording: nothing to compare yet")
        return
    if changed:
        console.print(
            f"changed from the first recording to the last (by {100 * MIN_SHARE:g} % or more "
            f"and beyond {K_SIGMA:g}σ): {len(changed)}"
        )
    else:
        console.print("nothing changed beyond its uncertainty from the first recording to the last")
    for s in changed:
        console.print(f"  {s.line()}", highlight=False, soft_wrap=True)
    if unjudged:
        console.print(f"moved by {100 * MIN_SHARE:g} % or more, but with no σ to judge it:")
        for s in unjudged:
            console.print(f"  {s.line()}", highlight=False, soft_wrap=True)
