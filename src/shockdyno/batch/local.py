"""The batch's local workers: N processes forked from the batch's own process.

The batch's process has already imported the fit, the diagnosis and the report, so a
forked worker starts with all of it: no interpreter start and no imports per worker, no
scheduler and no nannies (what Dask's LocalCluster spends on those does not grow with the
fits, and on a few cores it is a large part of a batch; benchmarks/bench_batch.py). Each worker is
given one task at a time over its own pipe, so this process always knows which recording
a worker holds: a worker that dies (killed, out of memory) has its recording run again on
a new worker, up to ALLOWED_FAILURES times, then the recording's row says so (Dask's
`allowed-failures`, 3). With other threads running in this process (a test runner's, a
caller's), a lock one of them holds would be inherited held: the workers are then spawned
(they import what they need, slower, and nothing outlives the batch). The workers ignore
SIGINT (Ctrl-C reaches the whole foreground process group: this process stops them), end
with this process (SIGTERM from the kernel if it dies, however) and are all stopped and
reaped when the batch ends, however it ends.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import pickle
import signal
import subprocess
import sys
import warnings
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from typing import Any, Generic, TypeVar

from shockdyno.diagnose.workers import can_fork, die_with_parent

T = TypeVar("T")
R = TypeVar("R")
ALLOWED_FAILURES = 3  # a recording whose workers died this often is a failed row
STOP_WAIT_S = 5.0  # a worker asked to stop that is still alive after this is killed


class WorkerDied(RuntimeError):
    """The recording's workers died under it ALLOWED_FAILURES times."""


def _serve(fn: Callable[[Any], Any], conn: Connection, parent: int) -> None:
    """A worker: fn(item) for each item received, its result (or exception) sent back,
    until told to stop or this process's pipe closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent(parent)
    for s in (signal.SIGTERM, signal.SIGHUP):  # the batch's own handlers are inherited
        signal.signal(s, signal.SIG_DFL)
    while True:
        try:
            item = conn.recv()
        except EOFError:
            return
        if item is None:
            return
        try:
            got: object = fn(item)
        except Exception as exc:  # the task raised: its row says so
            got = exc
        try:
            conn.send(got)
        except Exception as exc:  # an exception that does not pickle: its text
            conn.send(RuntimeError(f"{type(got).__name__}: {exc}"))


def _spawned() -> None:
    """A spawned worker's start: its pipe's descriptor and parent from argv; this
    process's import path, then the function, from the pipe."""
    conn = Connection(int(sys.argv[1]))
    sys.path[:] = conn.recv()  # where the function's module is found, as in the batch's
    _serve(pickle.loads(conn.recv_bytes()), conn, int(sys.argv[2]))


# SIGINT ignored first: a Ctrl-C while the interpreter imports is the batch's to handle.
SPAWN = (
    "import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "
    "from shockdyno.batch.local import _spawned; _spawned()"
)


class _Worker:
    """A worker process, forked or spawned, and this end of its pipe."""

    def __init__(self, fn: Callable[[Any], Any], fork: bool) -> None:
        self.conn, theirs = multiprocessing.Pipe()
        self.task: int | None = None  # the index of the item it holds
        self._forked: BaseProcess | None = None
        self._spawned: subprocess.Popen[bytes] | None = None
        try:
            if fork:
                self._forked = multiprocessing.get_context("fork").Process(
                    target=_serve, args=(fn, theirs, os.getpid()), daemon=True
                )
                with warnings.catch_warnings():
                    # Python >= 3.12 warns on any fork of a process with native threads. The
                    # only ones here are BLAS's pool (can_fork() saw one Python thread), and
                    # OpenBLAS re-makes its pool in the child (its pthread_atfork handlers).
                    warnings.filterwarnings(
                        "ignore", r"This process .* is multi-threaded", DeprecationWarning
                    )
                    self._forked.start()
            else:  # not multiprocessing's spawn: it starts a resource tracker that stays
                fd = str(theirs.fileno())
                self._spawned = subprocess.Popen(
                    [sys.executable, "-c", SPAWN, fd, str(os.getpid())],
                    pass_fds=[theirs.fileno()],
                    stdin=subprocess.DEVNULL,
                )
                # By value when it is a script's (`__main__` is not the worker's), as Dask
                # sends its tasks (cloudpickle comes with it; here only: forks need none).
                import cloudpickle

                self.conn.send(sys.path)
                self.conn.send_bytes(cloudpickle.dumps(fn))
        finally:
            theirs.close()

    def handles(self) -> list[Any]:
        """What becomes ready when it has sent a result or died."""
        return [self.conn] + ([self._forked.sentinel] if self._forked else [])

    def terminate(self) -> None:
        if self._forked is not None:
            self._forked.terminate()
        elif self._spawned is not None and self._spawned.poll() is None:
            self._spawned.terminate()

    def join(self, timeout: float) -> int | None:
        """Its exit code; killed first when it is still running after `timeout`."""
        if self._forked is not None:
            self._forked.join(timeout)
            if self._forked.exitcode is None:
                self._forked.kill()
                self._forked.join()
            code = self._forked.exitcode
            self._forked.close()
            self._forked = None
            return code
        if self._spawned is not None:
            try:
                self._spawned.wait(timeout)
            except subprocess.TimeoutExpired:
                self._spawned.kill()
                self._spawned.wait()
            return self._spawned.returncode
        return None


class LocalWorkers(Generic[T, R]):
    """`with LocalWorkers(fn, n) as w: for item, got in w.results(items): ...`: fn(item)
    for every item, yielded as each finishes (got: the result, or the exception). With
    `warm`, it is called here before the workers are forked, so that what it imports and
    loads is done once, not in each worker's first task."""

    def __init__(
        self, fn: Callable[[T], R], n: int, warm: Callable[[], None] | None = None
    ) -> None:
        self.fn = fn
        self.n = max(1, n)
        self.warm = warm  # run here first, when the workers are forked from here
        self.fork = can_fork()  # else spawned
        self._workers: list[_Worker] = []

    @property
    def start_method(self) -> str:
        return "fork" if self.fork else "spawn"

    def __enter__(self) -> LocalWorkers[T, R]:
        if self.warm is not None and self.fork:
            self.warm()
        try:
            for _ in range(self.n):
                self._workers.append(_Worker(self.fn, self.fork))
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def results(self, items: Sequence[T]) -> Iterator[tuple[T, R | BaseException]]:
        todo = deque(range(len(items)))
        deaths = [0] * len(items)
        while True:
            self._give_all(todo, items)
            busy = [w for w in self._workers if w.task is not None]
            if not busy:
                return
            ready = set(wait([h for w in busy for h in w.handles()]))
            finished: list[tuple[T, R | BaseException]] = []
            for w in busy:
                i = w.task
                if i is None or not ready.intersection(w.handles()):
                    continue
                w.task = None
                try:
                    finished.append((items[i], w.conn.recv()))  # sent before it died: counts
                except (EOFError, OSError):
                    deaths[i] += 1
                    code = self._replace(w)
                    if deaths[i] < ALLOWED_FAILURES:
                        todo.appendleft(i)
                    else:
                        why = f"its worker process died {deaths[i]} times (last exit code {code})"
                        finished.append((items[i], WorkerDied(why)))
            self._give_all(todo, items)  # before the caller's turn (a table to write)
            yield from finished

    def _give_all(self, todo: deque[int], items: Sequence[T]) -> None:
        for w in list(self._workers):
            if w.task is None and todo:
                self._give(w, todo.popleft(), items)

    def _give(self, w: _Worker, i: int, items: Sequence[T]) -> None:
        """items[i] to w or, if w died idle (not the item's doing), to its replacement."""
        try:
            w.conn.send(items[i])
        except OSError:
            self._replace(w)
            w = self._workers[-1]
            w.conn.send(items[i])
        w.task = i

    def _replace(self, dead: _Worker) -> int | None:
        """A new worker, last in the list, in dead's place; dead's exit code."""
        code = dead.join(STOP_WAIT_S)
        self._workers.remove(dead)
        dead.conn.close()
        self._workers.append(_Worker(self.fn, self.fork))
        return code

    def stop(self) -> None:
        """Every worker stopped and reaped: idle ones told to stop, busy ones (the batch
        was stopped) terminated; one that does not end within STOP_WAIT_S is killed."""
        for w in self._workers:
            if w.task is not None:
                w.terminate()
            else:
                with contextlib.suppress(OSError):  # it is gone already
                    w.conn.send(None)
        for w in self._workers:
            w.join(STOP_WAIT_S)
            w.conn.close()
        self._workers = []
