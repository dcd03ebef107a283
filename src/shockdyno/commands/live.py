"""`--live`, `--live-host`, `--live-port` of `sweep` and `replay` (docs/live.md)."""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from rich.console import Console
from rich.markup import escape

from shockdyno.errors import ConfigError
from shockdyno.live.server import DEFAULT_HOST, DEFAULT_PORT, LiveServer

if TYPE_CHECKING:  # imported when a live view starts (below)
    from shockdyno.live.publisher import LivePublisher

REPO = Path(__file__).resolve().parents[3]
LAYOUT = REPO / "recordings" / "foxglove-live-layout.json"  # docs/live.md


def add_live_arguments(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument(
        "--live",
        action="store_true",
        help=f"serve {what} live to Foxglove (a Foxglove WebSocket server; docs/live.md)",
    )
    p.add_argument(
        "--live-host",
        default=DEFAULT_HOST,
        metavar="HOST",
        help="with --live: the address to listen on (0.0.0.0: every interface)",
    )
    p.add_argument(
        "--live-port", type=int, default=DEFAULT_PORT, metavar="N", help="with --live: the port"
    )


@contextlib.contextmanager
def live_view(
    args: argparse.Namespace, console: Console, *, blocking: bool = False
) -> Iterator[LivePublisher | None]:
    """The live view's publisher while the block runs (None without --live), the server
    closed after it. A server that cannot start is a ConfigError before anything else."""
    if not getattr(args, "live", False):
        for flag, value, default in (
            ("--live-host", args.live_host, DEFAULT_HOST),
            ("--live-port", args.live_port, DEFAULT_PORT),
        ):
            if value != default:
                raise ConfigError(f"{flag} is for the live view: add --live")
        yield None
        return
    # Imported when a live view starts: +7 ms CPU at every command's start-up (measured).
    from shockdyno.live.publisher import LivePublisher

    server = LiveServer(args.live_host, args.live_port)

    def warn(text: str) -> None:
        console.print(f"[yellow]warning: {escape(text)}[/]", soft_wrap=True)

    publisher = LivePublisher(server, warn, blocking=blocking)
    console.print(
        f"live view: open {server.url} in Foxglove (Open connection → Foxglove WebSocket); "
        f"layout: {LAYOUT if LAYOUT.exists() else LAYOUT.relative_to(REPO)}",
        soft_wrap=True,
    )
    try:
        yield publisher
    finally:
        publisher.close()
        console.print(publisher.summary(), soft_wrap=True)
