"""Progress of a long command that is not a sweep (import, ride): stages and a fraction done.

The same pattern as the sweep's live view (run/liveview.py): on a terminal a rich progress bar
(stage, bar, percentage, elapsed time) that disappears when the command ends; anywhere else
(CI, pipes, files) one plain line per stage, no control codes. Both go to stderr, so standard
output keeps only the command's result.

A command whose early stages still check its input (import reads and validates each file)
sets `plain_after_s`: plain lines start only once it has run that long, so a quick run, and a
quick refusal of bad input, print nothing but their own one line.
"""

from __future__ import annotations

import os
import sys
from time import monotonic
from types import TracebackType

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

PIPE_WIDTH = 200  # columns of a table written to a pipe or a file: whole, not cut at 80


def table_console(stderr: bool = False) -> Console:
    """A console for result tables: on a terminal its own width; piped or redirected (no
    terminal, no COLUMNS) wide enough that a table is written whole (rich's 80 columns cut
    the fit's tables into ellipses in a log file)."""
    stream = sys.stderr if stderr else sys.stdout
    piped = not stream.isatty() and "COLUMNS" not in os.environ
    return Console(stderr=stderr, width=PIPE_WIDTH if piped else None)


class StageProgress:
    """`with StageProgress("import") as p: p.update("read a.csv", 0.25)`; fraction in [0, 1]."""

    def __init__(
        self, command: str, console: Console | None = None, *, plain_after_s: float = 0.0
    ) -> None:
        self.command = command
        self._plain_from = monotonic() + plain_after_s
        self.console = console or Console(stderr=True)
        self._last_stage: str | None = None
        self._bar: Progress | None = None
        self._task = None
        if self.console.is_terminal:
            self._bar = Progress(
                TextColumn(f"[bold]{command}[/] {{task.description}}"),
                BarColumn(),
                TextColumn("{task.percentage:>3.0f}%"),
                TimeElapsedColumn(),
                console=self.console,
                transient=True,
            )
            self._task = self._bar.add_task("", total=1.0)

    def update(self, stage: str, fraction: float) -> None:
        if self._bar is not None and self._task is not None:
            self._bar.update(self._task, description=stage, completed=fraction)
        elif stage != self._last_stage and monotonic() >= self._plain_from:
            # plain: one line per stage, not per update
            self.console.print(f"{self.command}: {stage}", highlight=False, soft_wrap=True)
        self._last_stage = stage

    def __call__(self, stage: str, fraction: float) -> None:
        self.update(stage, fraction)

    def __enter__(self) -> StageProgress:
        if self._bar is not None:
            self._bar.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._bar is not None:
            self._bar.stop()
