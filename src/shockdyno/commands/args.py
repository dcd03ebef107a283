"""Arguments several subcommands share, spelt once: the same flag means the same thing
(and says so in the same words) in every command that takes it."""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable
from pathlib import Path
from typing import TypeAlias

from shockdyno.errors import ConfigError, RigFault
from shockdyno.lists import seed_arg
from shockdyno.model.terms import LIBRARY
from shockdyno.result_files import not_a_recording
from shockdyno.rig.config import load_rig

# What `register(subparsers)` of each command module is given (argparse names no public
# class for it; a string, as the class is generic only to the type checker).
Subparsers: TypeAlias = "argparse._SubParsersAction[argparse.ArgumentParser]"


def add_rig(p: argparse._ActionsContainer) -> None:
    p.add_argument("--rig", type=Path, required=True, help="rig file, e.g. rigs/sim.toml")


def add_force(p: argparse._ActionsContainer, what: str) -> None:
    """--force: `what` names the file(s) it lets the command write over."""
    p.add_argument("--force", action="store_true", help=f"overwrite {what}")


def add_seed(p: argparse._ActionsContainer, of: str) -> None:
    # The help formatter adds "(default 0)" itself (cli.DefaultsHelpFormatter).
    p.add_argument("--seed", type=seed_arg, default=0, help=f"seed of {of}")


def add_term_list(p: argparse.ArgumentParser) -> None:
    """The physics term library, one line a term from the term's own `summary`."""
    lines = [f"{name}: {cls.summary}" for name, cls in LIBRARY.items()]
    p.add_argument_group("physics terms (--terms)", "\n".join(lines))


def add_spec(p: argparse._ActionsContainer, note: str = "") -> None:
    extra = f" ({note})" if note else ""
    p.add_argument(
        "--spec", metavar="PATH", help=f"base damper spec TOML{extra}; default sim/ohlins-s46.toml"
    )


def require_recording(path: str | Path, instead: str = "") -> None:
    """Refuse, in one line naming what it is, a file given as a recording that is another
    kind (`fit FIT.json` said only "not an MCAP file"); `instead` says where that kind
    goes. A file that starts as MCAP, or cannot be read, is left to the recording's reader."""
    found = not_a_recording(Path(path))
    if found is not None:
        raise ConfigError(
            f"{path}: not an MCAP file, but {found}; expected a recording (.mcap)"
            + (f" ({instead})" if instead else "")
        )


def unreachable_hint(rig_path: Path) -> str:
    """What to try when the rig file's drive or DAQ cannot be reached: the simulated rig
    (a rig file with a [simulation] table) may simply not be running."""
    try:
        simulated = bool(load_rig(rig_path).simulation)
    except ConfigError:
        simulated = False
    if simulated:
        return (
            f"; is the simulated rig running? start it in another terminal with "
            f"`shockdyno sim-rig --rig {rig_path}` (sweep can also start it: --start-sim)"
        )
    return (
        f"; is the drive powered and on this network (or its serial cable in), and are the "
        f"[actuator] and [daq] addresses in {rig_path} its own?"
    )


Command = Callable[[argparse.Namespace], int]


def hint_unreachable(command: Command) -> Command:
    """A rig command whose drive or DAQ cannot be reached says what to try (issue 47.8:
    "cannot connect" said nothing of the simulated rig not running)."""

    @functools.wraps(command)
    def run(args: argparse.Namespace) -> int:
        try:
            return command(args)
        except RigFault as exc:
            text = str(exc)
            if "cannot connect" not in text and "cannot open" not in text:
                raise
            raise RigFault(text + unreachable_hint(args.rig)) from None

    return run


def add_gas_arguments(p: argparse._ActionsContainer) -> None:
    """--gas-force-n and --spec of the commands that remove the gas force (report, compare)."""
    p.add_argument(
        "--gas-force-n",
        metavar="N|GAS:N,...",
        help="the damper's static gas force at mid-stroke, N: for every gas setting (231) or "
        "per gas clicks (0:231,5:260); replaces the measured or estimated one "
        "(default: measured, else estimated from the sine's reversals)",
    )
    add_spec(p, "its gas charge bounds an estimated gas force; a fit's damper when given")
