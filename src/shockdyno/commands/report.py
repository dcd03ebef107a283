"""`shockdyno report REC.mcap [--fit FIT.json] [--diagnose DIAG.json] [--ride RIDE.json] -o DIR`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rich.console import Console

from shockdyno.atomic import staged_dir
from shockdyno.commands.args import Subparsers, add_gas_arguments, require_recording
from shockdyno.errors import ConfigError, RecordingError
from shockdyno.fit import forces
from shockdyno.fit.result import FitResult
from shockdyno.model import load_spec
from shockdyno.outputs import check_report_dir
from shockdyno.record import open_recording
from shockdyno.record.identity import (
    add_allow_argument,
    provenance,
    recording_sha256,
)
from shockdyno.report import temperature
from shockdyno.report.clickchart import spec_static_force_n
from shockdyno.report.documents import (
    DiagnosisDoc,
    RideDoc,
    read_diagnosis,
    read_ride,
)
from shockdyno.report.gas import limit_for, parse_given
from shockdyno.result_files import RecordingRef
from shockdyno.units import add_argument as add_units_argument
from shockdyno.units import get as get_units


def register(sub: Subparsers) -> None:
    p = sub.add_parser(
        "report",
        help="one HTML page for a recording: click chart, loops, and fit/diagnose/ride if given",
        description=(
            "Write DIR/index.html (PNGs and click_chart.csv beside it; works offline) for any "
            "recording: real, imported or simulated. Sections for the fit, the diagnosis and "
            "the ride study appear when their JSON is given. Documented in docs/report.md."
        ),
    )
    p.add_argument("recording", metavar="REC.mcap", help="recording to report")
    p.add_argument("--fit", metavar="FIT.json", help="fit result of this recording (shockdyno fit)")
    p.add_argument("--diagnose", metavar="DIAG.json", help="result of shockdyno diagnose")
    p.add_argument("--ride", metavar="RIDE.json", help="result of shockdyno ride")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="report directory")
    p.add_argument("--title", help="page title (default: from the recording's metadata)")
    temperature.add_argument(p)
    p.add_argument(
        "--raw-force",
        action="store_true",
        help="click chart, summary and peak-force plot in raw force, gas force included "
        "(default: damping force, the gas force measured at mid-stroke, or estimated from "
        "the reversals, removed)",
    )
    add_gas_arguments(p)
    p.add_argument("--force", action="store_true", help="replace an existing DIR/index.html")
    add_allow_argument(p, "a --fit, --diagnose or --ride result")
    add_units_argument(p, "the page's numbers, tables and plots")
    p.set_defaults(func=run_report)


def check_output_dir(out: Path, inputs: list[Path], force: bool) -> None:
    """`-o DIR` of `report`: the shared report-directory policy."""
    check_report_dir(out, inputs, force, flag="-o")


def _gas_force(metadata: dict[str, str]) -> float | None:
    """Static gas force of the damper spec a simulated recording names, if readable."""
    spec = metadata.get("damper_spec", "")
    if not spec or not Path(spec).is_file():
        return None
    try:
        return spec_static_force_n(load_spec(spec))
    except ConfigError:
        return None


def _sha256(ref: RecordingRef | None) -> str | None:
    return (ref.sha256 or None) if ref is not None else None


def _provenance(
    args: argparse.Namespace,
    fit: FitResult | None,
    diagnose: DiagnosisDoc | None,
    ride: RideDoc | None,
    actual: str,
) -> dict[str, str]:
    """Each result given against the recording's hash: a page row each; a result of
    another recording (or of none it names) is refused unless --allow-other-recording
    (issue 46.7: --force used to waive it), and then said on the terminal as well."""
    given = []  # (row, what, flag, the hash it stores)
    if fit is not None:
        given.append(("fit", "the fit", "--fit", fit.info.recording_sha256))
    if diagnose is not None:
        given.append(("diagnosis", "the diagnosis", "--diagnose", _sha256(diagnose.info.recording)))
    if ride is not None:
        given.append(("ride", "the ride study's fit", "--ride", _sha256(ride.fit_recording)))
    if not given:
        return {}
    rows = {
        row: provenance(stored, actual, what, flag, args.allow_other_recording)
        for row, what, flag, stored in given
    }
    for line in rows.values():
        if not line.startswith("made from this recording"):
            print(f"report: warning: {line}", file=sys.stderr)
    return rows


def run_report(args: argparse.Namespace) -> int:
    # Imported when run: +460 ms CPU at start-up (matplotlib).
    from shockdyno.report.build import build_report

    require_recording(args.recording, "a result goes with --fit, --diagnose or --ride")
    given = parse_given(args.gas_force_n) if args.gas_force_n else None
    reference_c = temperature.reference_c(args.reference_temperature_c)
    out = Path(args.output)
    inputs = [Path(p) for p in (args.recording, args.fit, args.diagnose, args.ride) if p]
    check_output_dir(out, inputs, args.force)
    fit = FitResult.load(args.fit).require_usable(f"--fit {args.fit}") if args.fit else None
    given_any = args.fit or args.diagnose or args.ride
    actual = recording_sha256(Path(args.recording)) if given_any else ""
    # The model's forces the fit saved beside it: the page reads them.
    if fit is not None and (note := forces.attach(fit, args.fit, actual)):
        print(f"report: note: {note}", file=sys.stderr)
    diagnose = read_diagnosis(args.diagnose, "--diagnose") if args.diagnose else None
    ride = read_ride(args.ride, "--ride") if args.ride else None
    provenance_rows = _provenance(args, fit, diagnose, ride, actual)

    console = Console(stderr=True)
    with console.status("report: reading the recording") as status:
        rec = open_recording(args.recording)
        tests = rec.load_all() + [rec.load(m) for m in rec.interrupted]
        metadata = {"recording": str(args.recording), **rec.metadata, **provenance_rows}
        if rec.truncated:
            metadata["note"] = "the recording was cut off; every test it holds is shown"
        if not tests and rec.truncated:
            problem = next((p.problem for p in rec.parts if p.problem), "cut off")
            raise RecordingError(f"{args.recording}: no test could be read ({problem})")
        if not tests:
            console.print(f"report: {args.recording} holds no tests; writing the page anyway")
        title = args.title or (
            f"{rec.metadata.get('damper_id') or Path(args.recording).stem}: dyno report"
        )
        gas = None if fit is not None else _gas_force(rec.metadata)
        limit = limit_for(tests, args.spec, rec.metadata, fit.spec() if fit else None)

        def progress(stage: str) -> None:
            status.update(f"report: {stage}")

        with staged_dir(out) as folder:  # the page appears whole, or not at all
            build_report(
                tests,
                folder,
                title=title,
                metadata=metadata,
                fit=fit,
                diagnose=diagnose,
                ride=ride,
                gas_force_n=gas,
                progress=progress,
                warn=lambda text: console.print(
                    f"report: warning: {text}", markup=False, highlight=False, soft_wrap=True
                ),
                reference_temperature_c=reference_c,
                diagnose_dir=Path(args.diagnose).parent if args.diagnose else None,
                units=get_units(args.units),
                raw_force=args.raw_force,
                gas_given=given,
                gas_limit=limit,
            )
    if fit is not None and (note := forces.computed_note(fit, args.fit)):
        print(f"report: note: {note}", file=sys.stderr)
    print(f"report: {out / 'index.html'}")
    return 0
