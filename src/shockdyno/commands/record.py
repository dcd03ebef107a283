"""Commands `info` and `import` (`export` is in commands/export.py)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from shockdyno.commands.args import Subparsers, add_force, require_recording
from shockdyno.errors import ConfigError, RecordingError
from shockdyno.outputs import check_output, is_stdout, write_output
from shockdyno.progress import StageProgress
from shockdyno.record.csv_import import import_csv
from shockdyno.record.csv_table import (
    FORCE_UNITS,
    LENGTH_UNITS,
    MOTIONS,
    TEMPERATURE_UNITS,
    TIME_UNITS,
    ImportOptions,
)
from shockdyno.record.info import format_text, summarise
from shockdyno.record.layout import set_paths
from shockdyno.record.reader import open_recording
from shockdyno.result_files import starts_as_mcap


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "info",
        help="summarise a recording (tests, durations, dropped frames, faults)",
        description="Summarise a recording set; also works on a file cut off mid-test.",
    )
    p.add_argument("recording", type=Path, metavar="REC.mcap")
    p.add_argument(
        "--json",
        type=Path,
        metavar="PATH",
        help="also write the summary as JSON (- for stdout only)",
    )
    add_force(p, "an existing --json file")
    p.set_defaults(func=_info)

    p = subparsers.add_parser(
        "import",
        help="import CSV dyno data (exchange format or another dyno's export)",
        description="Import a manifest CSV and its data CSVs into one recording (docs/csv.md).",
    )
    p.add_argument("manifest", type=Path, metavar="MANIFEST.csv")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="REC.mcap")
    add_force(p, "an existing output")
    p.add_argument(
        "--allow-outside-files",
        action="store_true",
        help="let the manifest name data files outside its own folder",
    )
    p.add_argument(
        "--max-file-mb",
        type=float,
        default=1024.0,
        metavar="MB",
        help="refuse a manifest or data file larger than this (default 1024)",
    )
    d = ImportOptions()
    g = p.add_argument_group("data columns and units (defaults: the exchange format)")
    g.add_argument("--time-column", default=d.time_column, metavar="NAME")
    g.add_argument(
        "--time-unit",
        choices=TIME_UNITS,
        default=d.time_unit,
        help="s, ms, iso (ISO 8601 date-times, e.g. a Timestamp column) or auto (default)",
    )
    g.add_argument("--displacement-column", default=d.displacement_column, metavar="NAME")
    g.add_argument("--displacement-unit", choices=tuple(LENGTH_UNITS), default="m")
    g.add_argument("--force-column", default=d.force_column, metavar="NAME")
    g.add_argument("--force-unit", choices=tuple(FORCE_UNITS), default="N")
    g.add_argument(
        "--temperature-column", metavar="NAME", help="default: temperature_C when present"
    )
    g.add_argument("--temperature-unit", choices=TEMPERATURE_UNITS, default="C")
    g.add_argument(
        "--delimiter", default=",", metavar="CHAR", help="field separator (default ','; tab: '\\t')"
    )
    g = p.add_argument_group("test settings the manifest may leave out")
    g.add_argument(
        "--sample-rate-hz",
        type=float,
        metavar="HZ",
        help="default: manifest column, else 1/median time step",
    )
    g.add_argument(
        "--motion",
        choices=MOTIONS,
        help="imported: non-sinusoidal motion (default: manifest column, else sine)",
    )
    g.add_argument(
        "--gas-clicks", type=int, default=0, metavar="N", help="when no gas_clicks column (0)"
    )
    g.add_argument(
        "--meta",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="recording metadata, e.g. damper_id=S46-0123 operator=ana (repeatable)",
    )
    p.set_defaults(func=_import)


def _info(args: argparse.Namespace) -> int:
    inputs = set_paths(args.recording)
    if args.json is not None:
        check_output(args.json, force=args.force, inputs=inputs)
    require_recording(args.recording)
    doc = summarise(open_recording(args.recording).require_recording())
    if not is_stdout(args.json):
        print(format_text(doc))
    if args.json is not None:
        write_output(args.json, json.dumps(doc, indent=2) + "\n", force=args.force, inputs=inputs)
    return 0


def _meta_pairs(pairs: list[str]) -> dict[str, str]:
    out = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise RecordingError(f"--meta {pair!r}: expected KEY=VALUE")
        out[key.strip()] = value
    return out


def _import(args: argparse.Namespace) -> int:
    opts = ImportOptions(
        time_column=args.time_column,
        time_unit=args.time_unit,
        displacement_column=args.displacement_column,
        displacement_unit=args.displacement_unit,
        force_column=args.force_column,
        force_unit=args.force_unit,
        temperature_column=args.temperature_column,
        temperature_unit=args.temperature_unit,
        sample_rate_hz=args.sample_rate_hz,
        motion=args.motion,
        gas_clicks=args.gas_clicks,
        delimiter="\t" if args.delimiter in ("\\t", "tab") else args.delimiter,
        metadata=_meta_pairs(args.meta),
        allow_outside=args.allow_outside_files,
        max_file_bytes=int(args.max_file_mb * 1e6),
    )
    if args.manifest.is_file() and starts_as_mcap(args.manifest):
        raise ConfigError(
            f"{args.manifest} is an MCAP recording; import reads a manifest CSV "
            "(shockdyno export REC.mcap --csv DIR writes one from a recording)"
        )
    if args.manifest.exists() and args.output.exists() and args.output.samefile(args.manifest):
        raise RecordingError(f"-o {args.output} is the manifest; refusing to overwrite it")
    with StageProgress("import", plain_after_s=2.0) as progress:
        tests = import_csv(args.manifest, args.output, opts, force=args.force, progress=progress)
    print(f"imported {len(tests)} tests from {args.manifest} into {args.output}")
    return 0
