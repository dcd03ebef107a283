"""`shockdyno batch fit|diagnose|report PATHS... --out DIR [--scheduler ADDRESS] [--workers N]`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

from shockdyno.batch.table import KINDS, Row, earlier_rows
from shockdyno.commands.args import Subparsers, add_seed, add_spec
from shockdyno.commands.history import add_history_argument, database
from shockdyno.diagnose.file import parse_candidates
from shockdyno.errors import ConfigError
from shockdyno.fit.terms import parse_terms
from shockdyno.record.identity import add_allow_argument
from shockdyno.run.signals import stop_on_signals

if TYPE_CHECKING:  # the batch's runner and jobs are imported when it runs (below)
    from shockdyno.batch.jobs import Options


def register(sub: Subparsers) -> None:
    p = sub.add_parser(
        "batch",
        help="fit, diagnose or report many recordings (local processes or a Dask scheduler)",
        description=(
            "Run `fit`, `diagnose` or `report` on every recording in PATHS (files, folders, "
            "globs), one task a recording: on worker processes of this machine, or on an "
            "existing Dask cluster (--scheduler). Writes DIR/NAME.fit.json, "
            "NAME.diag.json or NAME/index.html, and DIR/results.parquet and results.csv. "
            "A recording whose result exists for the same content, options and version is "
            "skipped; a bad recording is a row with its error (docs/batch.md)."
        ),
    )
    p.add_argument("kind", choices=KINDS)
    p.add_argument("paths", nargs="+", metavar="PATHS")
    p.add_argument("--out", required=True, type=Path, metavar="DIR")
    p.add_argument(
        "--scheduler", metavar="ADDRESS", help="an existing cluster, e.g. tcp://10.0.0.5:8786"
    )
    p.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="local worker processes (default: the cores this process may run on)",
    )
    g = p.add_argument_group("options passed to each command")
    g.add_argument("--terms", metavar="LIST", help="fit: default sensor_lag; diagnose: all")
    add_spec(g)
    g.add_argument("--alpha", type=float, default=0.01, help="diagnose: significance")
    add_seed(g, "the GA (fit) and the bootstrap (diagnose)")
    g.add_argument("--optimizer", choices=("fast", "ga"), default="fast", help="fit")
    g.add_argument(
        "--fit",
        metavar="FILE|DIR",
        help="diagnose/report: a fit JSON for all, or a folder of NAME.fit.json (a batch fit's)",
    )
    add_allow_argument(g, "a --fit (diagnose/report)")
    add_history_argument(p)
    p.set_defaults(func=run)


def _options(args: argparse.Namespace) -> Options:
    opts: Options = {"seed": args.seed}
    if args.spec:
        opts["spec"] = str(Path(args.spec).resolve())
    if args.fit:
        opts["fit"] = str(Path(args.fit).resolve())
        if args.allow_other_recording:  # in the key: a result made without it is redone
            opts["allow_other_recording"] = True
    if args.kind == "fit":
        opts["optimizer"] = args.optimizer
        if args.terms is not None:
            parse_terms(args.terms)  # refused now, not once per recording
            opts["terms"] = args.terms
    if args.kind == "diagnose":
        if not 0 < args.alpha < 1:
            raise ConfigError(f"--alpha must be between 0 and 1, got {args.alpha}")
        opts["alpha"] = args.alpha
        opts["terms"] = args.terms or "all"
        parse_candidates(opts["terms"])
    return opts


def run(args: argparse.Namespace) -> int:
    # Imported when a batch runs: +7 ms CPU at every command's start-up otherwise (runner,
    # with jobs; measured).
    from shockdyno.batch.jobs import computed_notes, missing_fits, sidecar_notes
    from shockdyno.batch.runner import collect, plan_jobs, run_batch

    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers must be at least 1, got {args.workers}")
    out: Path = args.out
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {out}: is a file, not a directory")
    options = _options(args)
    if options.get("allow_other_recording"):
        print(
            "batch: --allow-other-recording: a --fit made from another recording is used "
            "(each result says so)",
            file=sys.stderr,
        )
    kept = earlier_rows(out)  # a damaged table is refused before any work
    recordings = collect(args.paths)
    jobs = plan_jobs(args.kind, recordings, out.resolve(), options)
    missing = missing_fits(jobs)
    if missing:  # as the single command without --fit: said, not silent
        names = ", ".join(missing[:5]) + (
            f" and {len(missing) - 5} more" if len(missing) > 5 else ""
        )
        print(
            f"batch: warning: --fit {args.fit}: no NAME.fit.json for {len(missing)} of "
            f"{len(jobs)} recordings ({names}): they run without a fit",
            file=sys.stderr,
        )
    for note in sidecar_notes(jobs):  # as `report` says it: the page is the same
        print(f"batch report: note: {note}", file=sys.stderr)
    console = Console(stderr=True)
    counts = {"done": 0, "skipped": 0, "failed": 0}
    # Redrawn as results arrive, not by a thread: the local workers are forked from this
    # process, which it keeps to one thread (batch/local.py). SIGTERM and SIGHUP unwind
    # as Ctrl-C does: the workers stopped, the table written with every finished row.
    with (
        stop_on_signals(),
        Progress(
            TextColumn("batch " + args.kind),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[counts]}"),
            console=console,
            disable=not console.is_terminal,
            auto_refresh=False,
        ) as bar,
    ):
        task = bar.add_task("batch", total=len(jobs), counts="")

        def progress(row: Row, n: int, total: int) -> None:
            counts[row.status] = counts.get(row.status, 0) + 1
            text = ", ".join(f"{v} {k}" for k, v in counts.items()) + f", {total - n} to go"
            bar.update(task, completed=n, counts=text, refresh=True)
            if not console.is_terminal:
                line = f"batch: {n}/{total} {row.status} {row.name}"
                print(line + (f": {row.error}" if row.error else ""), file=sys.stderr)

        def on_cluster(where: str) -> None:
            plural = "s" if len(jobs) != 1 else ""
            console.print(f"batch: {len(jobs)} recording{plural} on {where}")

        history = None if args.no_history or args.kind == "report" else database(args)
        rows = run_batch(
            jobs,
            out,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=progress,
            on_cluster=on_cluster,
            history=history,
            warn=lambda text: print(f"batch: warning: {text}", file=sys.stderr),
        )
    for note in computed_notes(jobs, rows):  # as `report` says it, once per fit
        print(f"batch report: note: {note}", file=sys.stderr)
    return _print_outcome(args.kind, rows, kept, counts, len(jobs), out, history)


def _print_outcome(
    kind: str,
    rows: list[Row],
    kept: list[Row],
    counts: dict[str, int],
    n_jobs: int,
    out: Path,
    history: Path | None,
) -> int:
    """The batch's last lines: done, skipped and failed of all, where the table is (and
    how many rows of earlier runs it keeps), the history's additions, each failure; the
    exit code (3 when a recording failed)."""
    failed = [r for r in rows if r.status == "failed"]
    ran = {(r.name, r.kind) for r in rows}
    others = sum((r.name, r.kind) not in ran for r in kept)
    print(
        f"batch {kind}: {counts['done']} done, {counts['skipped']} skipped, "
        f"{len(failed)} failed of {n_jobs}; table {out / 'results.parquet'} and .csv"
        + (f" (with {others} rows of earlier runs)" if others else "")
    )
    if history is not None:
        added = sum(r.status in ("done", "skipped") for r in rows)
        print(f"history: {added} results kept in {history}")
    for r in failed:
        print(f"  failed {r.path}: {r.error}")
    return 3 if failed else 0
