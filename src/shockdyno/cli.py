"""The `shockdyno` command. Each area registers its own subcommands.

Every user mistake or rig problem arrives here as a ShockdynoError and is printed as one
line with a non-zero exit code; only a bug gives a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
from collections.abc import Sequence

from shockdyno import __version__
from shockdyno.errors import ShockdynoError

# Modules with `register(subparsers)`; each subcommand sets `func(args) -> int`.
COMMAND_MODULES = [
    "shockdyno.run.cli",  # demo, sweep, replay
    "shockdyno.simrig.cli",  # sim-rig
    "shockdyno.record.cli",  # info, import, export
    "shockdyno.fit.cli",  # fit
    "shockdyno.ride.cli",  # ride
    "shockdyno.diagnose.cli",  # diagnose
    "shockdyno.report.cli",  # report
]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="shockdyno",
        description="Shock-absorber dyno controller, MCAP data logger and damper model.",
    )
    parser.add_argument("--version", action="version", version=f"shockdyno {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name is None or not name.startswith(exc.name):  # a real missing dependency
                raise
            continue
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code = args.func(args)
    except ShockdynoError as exc:
        print(f"shockdyno {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except OSError as exc:  # a path the user named cannot be read or written
        where = f": {exc.filename}" if exc.filename else ""
        print(f"shockdyno {args.command}: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        name = (
            "interrupted"
            if signum == signal.SIGINT
            else f"stopped by {signal.Signals(signum).name}"
        )
        print(f"shockdyno {args.command}: {name}", file=sys.stderr)
        return 128 + int(signum)
    return int(code or 0)


if __name__ == "__main__":
    sys.exit(main())
