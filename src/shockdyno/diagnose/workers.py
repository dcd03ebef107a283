"""The search's independent refits (a round's candidates, the held-out folds) on more
than one core.

Each item is a pure function of the round's inputs (the bootstrap's draws are made
before, in this process), so the results are those of running them one after another,
in the same order; only the wall time changes. The worker processes live for one
diagnosis. They are forked from this process when it runs one thread (they inherit what
it imported and compiled), at the first map that needs them, not before: forked after the
baseline fit, they inherit scipy's optimisers and the numba kernels and registries the
fit loaded, which each worker forked at the start loaded again in its first refit (about
a second of CPU each, most of it in the round's first candidates, while the other core
waited). With other threads running (a progress bar's refresh), a lock one of them holds
would be inherited held, so they come from a fork server started with the diagnosis
imported instead, at once, so that its imports overlap the baseline fit (its workers
import the main module again, as spawned ones do: a script needs Python's
`if __name__ == "__main__":`). Serial with one worker, and in a daemonic process (a Dask
worker running `batch diagnose` may not have children)."""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from multiprocessing.context import BaseContext
from types import TracebackType
from typing import TypeVar

S = TypeVar("S")
T = TypeVar("T")
R = TypeVar("R")

PRELOAD = ["shockdyno.diagnose.engine"]  # what each worker would otherwise import itself
PR_SET_PDEATHSIG = 1  # linux/prctl.h


def usable_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def can_fork() -> bool:
    """Workers may be forked from this process: the platform forks, and this process runs
    one thread (a lock another thread holds would be inherited held)."""
    return "fork" in multiprocessing.get_all_start_methods() and threading.active_count() == 1


def _context() -> BaseContext | None:
    """How to start the workers (None: not at all, run here)."""
    if multiprocessing.current_process().daemon:
        return None
    if can_fork():
        return multiprocessing.get_context("fork")
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)
        return ctx
    return None


def die_with_parent(parent: int | None) -> None:
    """A worker's start: it ends when the process that started it does (a diagnosis or a
    batch killed by SIGTERM or SIGKILL would otherwise leave its workers computing,
    forever waiting for the next item)."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if parent is not None and os.getppid() != parent:
        os._exit(1)  # it died before the line above took effect


def _ready() -> int:
    return os.getpid()


class Workers:
    """`with Workers(n) as w: w.map(fn, shared, items)` = [fn(shared, x) for x in items]."""

    def __init__(self, n: int = 1) -> None:
        self.n = n
        self._pool: ProcessPoolExecutor | None = None
        self._deferred = False  # to be forked at the first map that needs them
        self.start_method = ""  # how the workers are started ("": none, items run here)

    def __enter__(self) -> Workers:
        ctx = _context() if self.n > 1 else None
        if ctx is not None:
            self._deferred = True
            self.start_method = ctx.get_start_method()
            if self.start_method != "fork":
                self._started()  # the fork server's imports overlap the baseline fit
        return self

    def _started(self) -> ProcessPoolExecutor | None:
        """The pool, started at the first call (None: the items run here)."""
        if self._pool is None and self._deferred:
            self._deferred = False
            ctx = _context()  # again: a thread started since rules a fork out
            if ctx is None:
                self.start_method = ""
                return None
            self.start_method = ctx.get_start_method()
            # A forked worker's parent is this process; a fork server's, the server (which
            # ends with this process).
            parent = os.getpid() if self.start_method == "fork" else None
            self._pool = ProcessPoolExecutor(
                self.n, mp_context=ctx, initializer=die_with_parent, initargs=(parent,)
            )
            for _ in range(self.n):  # every worker started now, not one per item as asked
                self._pool.submit(_ready)
        return self._pool

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._deferred = False
        if self._pool is not None:
            if kind is not None:
                # Stopped (Ctrl-C, an error): what the workers are on will not be used.
                for p in getattr(self._pool, "_processes", {}).values():
                    p.terminate()
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
            self.start_method = ""

    def map(
        self,
        fn: Callable[[S, T], R],
        shared: S,
        items: Sequence[T],
        done: Callable[[int], None] | None = None,
    ) -> list[R]:
        """[fn(shared, x) for x in items]; `done(i)` is called here as item i finishes
        (for progress). `fn` is a module-level function (it is sent by name)."""
        pool = self._started() if len(items) >= 2 else None
        if pool is None:
            out = []
            for i, x in enumerate(items):
                out.append(fn(shared, x))
                if done is not None:
                    done(i)
            return out
        futures: dict[Future[R], int] = {pool.submit(fn, shared, x): i for i, x in enumerate(items)}
        results: dict[int, R] = {}
        try:
            for fut in as_completed(futures):
                i = futures[fut]
                results[i] = fut.result()
                if done is not None:
                    done(i)
        except BaseException:
            for fut in futures:
                fut.cancel()  # what has not started would be wasted
            raise
        return [results[i] for i in range(len(items))]


SERIAL = Workers(1)
