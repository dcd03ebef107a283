"""`shockdyno diagnose REC.mcap [--fit FIT.json] [--terms LIST] --json DIAG.json [--report DIR]`."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from shockdyno import units as units_mod
from shockdyno.errors import ConfigError
from shockdyno.lists import seed_arg


def register(sub: Any) -> None:
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
        help="candidate terms, comma-separated, or 'all' (the whole library)",
    )
    p.add_argument("--report", metavar="DIR", help="also write figures and index.html here")
    p.add_argument("--spec", metavar="PATH", help="base damper spec TOML (without --fit)")
    p.add_argument("--alpha", type=float, default=0.01, help="significance level of a claim")
    p.add_argument("--seed", type=seed_arg, default=0, help="seed of the bootstrap")
    p.add_argument(
        "--force",
        action="store_true",
        help="overwrite an existing DIAG.json or --report page; accept a --fit made from "
        "another recording (DIAG.json says so)",
    )
    units_mod.add_argument(p, "the terminal text, table and --report page")
    p.set_defaults(func=run_diagnose)


def _candidates(text: str) -> tuple[str, ...]:
    from shockdyno.fit.terms import split_terms
    from shockdyno.model.terms import LIBRARY

    items = split_terms(text)
    if items == ["all"]:
        return tuple(LIBRARY)
    if "none" in items:
        raise ConfigError("--terms none: diagnose needs at least one candidate term (or all)")
    names = tuple(dict.fromkeys(items))
    for n in names:
        if n not in LIBRARY:
            raise ConfigError(f"--terms: unknown term {n!r} (one of {', '.join(LIBRARY)})")
    return names


def _summary(doc: dict[str, Any], units: units_mod.Units = units_mod.SI) -> Any:
    from rich.table import Table

    from shockdyno.diagnose.verdict import in_units

    table = Table(title="Candidate physics (refitted with globals and areas)")
    effect = f"peak effect {units.force_label}"
    for name in ("round", "physics", "claimed", "p", "held-out gain", effect, "note"):
        table.add_column(name, justify="left" if name in ("physics", "note") else "right")
    for f in doc["findings"]:
        gain = f["heldout_gain"]
        note = in_units(f["why_not"], units) or (
            "alike: " + ", ".join(f["ambiguous_with"]) if f["ambiguous_with"] else ""
        )
        table.add_row(
            str(f["round"]),
            f["physics"],
            "[bold green]yes[/]" if f["claimed"] else "",
            f"{f['p_value']:.3g}",
            "–" if gain is None else f"{gain:.2f}",
            f"{units.force(f['effect_peak_n']):.3g}",
            note,
        )
    return table


def diagnose_file(
    recording: Path,
    *,
    fit_path: str | None = None,
    spec: str | None = None,
    alpha: float = 0.01,
    seed: int = 0,
    terms: str = "all",
    force: bool = False,
    progress: Any = None,
    warn: Any = None,
) -> tuple[Any, dict[str, Any]]:
    """`shockdyno diagnose` on one recording, as `batch diagnose` runs it too: the
    Diagnosis and its DIAG.json document (with `info.recording` and the fit's
    provenance)."""
    from shockdyno.diagnose.engine import Settings, diagnose
    from shockdyno.diagnose.verdict import to_json
    from shockdyno.fit.result import FitResult
    from shockdyno.model import load_spec
    from shockdyno.model.spec import spec_used
    from shockdyno.record import open_recording
    from shockdyno.record.identity import provenance, recording_info, stored_sha256

    if not 0 < alpha < 1:
        raise ConfigError(f"--alpha must be between 0 and 1, got {alpha}")
    settings = Settings(alpha=alpha, seed=seed, candidates=_candidates(terms))
    fit = FitResult.load(fit_path).require_usable(f"--fit {fit_path}") if fit_path else None
    if fit is None:
        load_spec(spec)  # a bad spec fails before reading the recording
    info = recording_info(recording)
    fit_from = None
    if fit is not None:
        stored = stored_sha256(fit.info, "recording", "sha256")
        fit_from = provenance(stored, info["sha256"], "the fit", "--fit", force)
    rec = open_recording(recording).require_recording()
    loss = rec.loss_note()
    if loss and warn is not None:
        warn(f"warning: {recording}: {loss}")
    tests = rec.load_all()
    if not tests:
        raise ConfigError(f"{recording}: no tests to diagnose")
    d = diagnose(tests, fit, settings, progress, spec_path=spec)
    doc = to_json(d)
    doc["info"]["recording"] = info
    # Which damper spec the model started from: --spec, the fit's base spec, or the default.
    doc["info"]["spec"] = spec_used(fit.spec_path if fit is not None else spec)
    if fit is not None:
        doc["info"]["spec"]["from_fit"] = str(fit_path)
    if loss:
        doc["info"]["recording_loss"] = loss
    if fit_from is not None:
        doc["info"]["fit_provenance"] = fit_from
    return d, doc


def run_diagnose(args: argparse.Namespace) -> int:

    from shockdyno.model import load_spec
    from shockdyno.outputs import check_output, check_report_dir, write_output
    from shockdyno.progress import StageProgress, table_console
    from shockdyno.record.layout import set_paths

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
    _candidates(args.terms)  # a bad list fails before anything is read
    with StageProgress("diagnose") as progress:
        d, doc = diagnose_file(
            Path(args.recording),
            fit_path=args.fit,
            spec=args.spec,
            alpha=args.alpha,
            seed=args.seed,
            terms=args.terms,
            force=args.force,
            progress=progress,
            warn=lambda line: print(line, file=sys.stderr),
        )
    if args.report:  # DIAG.json names the figures drawn below, for `report --diagnose`
        from shockdyno.diagnose.report import figure_paths

        doc["info"]["figures"] = figure_paths(Path(args.report), args.json)
        doc["info"]["figures_units"] = args.units  # report says so if its page's differ
    text = json.dumps(doc, indent=2, allow_nan=False) + "\n"
    # Written before the figures are drawn: a plotting failure must not lose the diagnosis.
    write_output(args.json, text, force=args.force, inputs=inputs)
    shown = table_console(stderr=out is None)
    from shockdyno.model.spec import spec_line

    used = doc["info"]["spec"]
    via = f", the base spec of {used['from_fit']}" if "from_fit" in used else ""
    shown.print(spec_line(used) + via, soft_wrap=True, highlight=False, markup=False)
    m = doc["mismatch"]
    if doc["short_tests"]:  # a warning, not an error: the rest of the diagnosis stands
        n = len(doc["short_tests"])
        print(
            f"warning: {n} test{'s' * (n > 1)} of fewer than two whole cycles: nothing "
            "claimed from them (no cycle-to-cycle noise to test against)",
            file=sys.stderr,
        )
    units = units_mod.get(args.units)
    fl = units.force_label
    if not m["tested"]:
        shown.print("mismatch: not tested (no test has two whole cycles)")
    else:
        shown.print(
            f"mismatch: {'[bold red]significant[/]' if m['significant'] else 'none beyond noise'} "
            f"(p = {m['p_value']:.3g}); structure {units.force(m['structured_rms_n']):.3g} {fl} "
            f"RMS, noise {units.force(m['noise_floor_n']):.3g} {fl}, about "
            f"{m['effective_values']:.0f} independent values"
        )
    if m["significant"]:
        shown.print(_summary(doc, units))
    text = doc["verdict"]["text_imperial" if units.imperial else "text"]
    shown.print(f"[bold]verdict:[/] {text}")
    if args.report:
        from shockdyno.diagnose.report import write_report

        index = write_report(d, doc, Path(args.report), units)
        shown.print(f"report: {index}")
    if out is not None:
        shown.print(f"wrote {out} in {d.wall_s:.1f} s")
    return 0
