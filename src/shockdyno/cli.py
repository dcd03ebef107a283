"""The `shockdyno` command. Each area registers its own subcommands.

Every user mistake or rig problem arrives here as a ShockdynoError and is printed as one
line with a non-zero exit code; only a bug gives a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import logging
import os
import signal
import sys
from collections.abc import Sequence

from shockdyno import __version__
from shockdyno.errors import ShockdynoError

# Modules with `register(subparsers)`; each subcommand sets `func(args) -> int`.
COMMAND_MODULES = [
    "shockdyno.commands.run",  # demo, sweep, replay
    "shockdyno.commands.simrig",  # sim-rig
    "shockdyno.commands.rig",  # rig check | jog | tare
    "shockdyno.commands.record",  # info, import
    "shockdyno.commands.export",  # export (a recording to CSV, a fit to damper tables)
    "shockdyno.commands.fit",  # fit
    "shockdyno.commands.ride",  # ride
    "shockdyno.commands.diagnose",  # diagnose
    "shockdyno.commands.report",  # report
    "shockdyno.commands.compare",  # compare
    "shockdyno.commands.batch",  # batch
    "shockdyno.commands.history",  # history
]


LOG_LEVELS = ("debug", "info", "warning", "error")


class DefaultsHelpFormatter(argparse.HelpFormatter):
    """--help shows every option's default: "(default: X)" after the help text, unless the
    text already says it or there is none to show (no default, a flag that is off, an empty
    string or list)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if (
            "default" in text.lower()
            or default is None
            or default is False
            or default in ([], "")
            or default is argparse.SUPPRESS
            or not action.option_strings
        ):
            return text
        return f"{text} (default: %(default)s)" if text else "(default: %(default)s)"

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        # A description's own line breaks are kept (the term list: a term a line).
        return "\n".join(super(DefaultsHelpFormatter, self)._fill_text(line, width, indent)
                         for line in text.splitlines())  # fmt: skip


def _add_logging_options(parser: argparse.ArgumentParser, default: object) -> None:
    group = parser.add_argument_group("logging")
    group.add_argument(
        "-v",
        "--verbose",
        dest="log_level",
        action="store_const",
        const="debug",
        default=default,
        help="same as --log-level debug: shows the Modbus traffic (pymodbus) on stderr",
    )
    group.add_argument(
        "--log-level",
        choices=LOG_LEVELS,
        default=default,
        help="log shockdyno and pymodbus to stderr at this level; default: warnings only",
    )


def configure_logging(level_name: str | None) -> None:
    """Log to stderr at the level asked; without one, leave logging as the libraries set it."""
    if level_name is None:
        return
    level = getattr(logging, level_name.upper())
    # Other libraries (matplotlib, asyncio) stay at warnings: their debug output is not ours.
    logging.basicConfig(
        level=logging.WARNING,
        stream=sys.stderr,
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
    )
    # The actuator driver quiets pymodbus (one RigFault line per failure is enough in normal
    # use); an explicit level wins, so commissioning a drive can watch every request.
    for name in ("shockdyno", "pymodbus"):
        logging.getLogger(name).setLevel(level)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="shockdyno",
        description="Shock-absorber dyno controller, MCAP data logger and damper model.",
        formatter_class=DefaultsHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"shockdyno {__version__}")
    _add_logging_options(parser, None)
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
    for command in sub.choices.values():
        for each in _with_nested(command):  # `rig check` too, not only `rig`
            each.formatter_class = DefaultsHelpFormatter
            # SUPPRESS: an option given before the command is not reset by the command's default
            _add_logging_options(each, argparse.SUPPRESS)
            # What its one-line errors start with, as argparse's own do: "shockdyno rig
            # jog", not "shockdyno rig" (the innermost parser's default wins).
            each.set_defaults(command_prog=each.prog)
    return parser


def _with_nested(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """A command's parser and those of its own subcommands."""
    out = [parser]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                out.extend(_with_nested(child))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    try:
        # Imports every command's module: seconds on a loaded machine, and a Ctrl-C in
        # them is an interrupt like any other, not a traceback.
        parser = build_parser()
    except KeyboardInterrupt:
        print("shockdyno: interrupted", file=sys.stderr)
        return 128 + int(signal.SIGINT)
    args = parser.parse_args(argv)
    configure_logging(args.log_level)
    prog = args.command_prog
    try:
        code = args.func(args)
    except ShockdynoError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except BrokenPipeError:  # the reader of the output went away (`| head`): not an error
        with contextlib.suppress(OSError):  # nor at exit, when Python flushes stdout again
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # a path the user named cannot be read or written
        where = f": {exc.filename}" if exc.filename else ""
        print(f"{prog}: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        name = (
            "interrupted"
            if signum == signal.SIGINT
            else f"stopped by {signal.Signals(signum).name}"
        )
        print(f"{prog}: {name}", file=sys.stderr)
        return 128 + int(signum)
    return int(code or 0)


if __name__ == "__main__":
    sys.exit(main())
