"""`shockdyno ARGS` run in the test's own process: `main()` with its standard output and
error captured, returned as a subprocess would return them.

A `shockdyno` process costs about a second of CPU to start (Python, NumPy, numba's cached
kernels), several on a loaded machine; the suite started hundreds. Tests that check what a
command says, writes and returns use this; tests of the process itself (signals, a kill,
the console entry point, a lock held by another process) start a real one.
"""

from __future__ import annotations

import io
import subprocess
import sys
from contextlib import redirect_stderr, redirect_stdout

from shockdyno.cli import main


def cli(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    """Run `shockdyno *args` here; `stdin` given: standard input is that text, not a
    terminal (as `stdin=subprocess.DEVNULL` is for a process)."""
    out, err = io.StringIO(), io.StringIO()
    saved = sys.stdin
    if stdin is not None:
        sys.stdin = io.StringIO(stdin)
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exc:  # argparse's usage errors, --help
                code = exc.code if isinstance(exc.code, int) else 1 if exc.code else 0
    finally:
        sys.stdin = saved
    return subprocess.CompletedProcess(["shockdyno", *args], code, out.getvalue(), err.getvalue())
