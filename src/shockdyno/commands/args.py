"""Arguments several subcommands share, spelt once: the same flag means the same thing
(and says so in the same words) in every command that takes it."""

from __future__ import annotations

import argparse
from pathlib import Path

from shockdyno.lists import seed_arg


def add_rig(p: argparse._ActionsContainer) -> None:
    p.add_argument("--rig", type=Path, required=True, help="rig file, e.g. rigs/sim.toml")


def add_force(p: argparse._ActionsContainer, what: str) -> None:
    """--force: `what` names the file(s) it lets the command write over."""
    p.add_argument("--force", action="store_true", help=f"overwrite {what}")


def add_seed(p: argparse._ActionsContainer, of: str) -> None:
    p.add_argument("--seed", type=seed_arg, default=0, help=f"seed of {of} (default 0)")


def add_term_list(p: argparse.ArgumentParser) -> None:
    """The physics term library, one line a term from the term's own `summary`."""
    from shockdyno.model.terms import LIBRARY

    lines = [f"{name}: {cls.summary}" for name, cls in LIBRARY.items()]
    p.add_argument_group("physics terms (--terms)", "\n".join(lines))


def add_spec(p: argparse._ActionsContainer, note: str = "") -> None:
    extra = f" ({note})" if note else ""
    p.add_argument(
        "--spec", metavar="PATH", help=f"base damper spec TOML{extra}; default sim/ohlins-s46.toml"
    )
