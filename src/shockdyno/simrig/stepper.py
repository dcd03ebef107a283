"""The thread a slow plant steps in, so the simulated rig's loop answers Modbus meanwhile.

One step at a time, in order, its result handed to the loop as an asyncio future. The
thread is a daemon and nothing waits for it without a bound: a step that never returns
(a plant stuck in its solver) must not keep the process alive after its session ended.
A `concurrent.futures` executor did: its threads are joined at interpreter exit, so a
sweep that had printed its error, stopped and disabled the drive, never exited.
"""

from __future__ import annotations

import asyncio
import contextlib
import queue
import threading
from collections.abc import Callable
from typing import Any, TypeVar

from shockdyno import priority

T = TypeVar("T")

# Any: one queue holds jobs of every result type, and a Future is invariant in it.
_Job = tuple[
    asyncio.AbstractEventLoop, "asyncio.Future[Any]", Callable[..., object], tuple[object, ...]
]


class Stepper:
    """A daemon thread that runs a slow plant's steps one at a time, in order, each result handed
    to the event loop as a future."""

    def __init__(self, nice: int | None = None, name: str = "sim-plant") -> None:
        """`nice`: the niceness the steps run at (None: the calling thread's)."""
        self._jobs: queue.SimpleQueue[_Job | None] = queue.SimpleQueue()
        self._nice = nice
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def submit(
        self, loop: asyncio.AbstractEventLoop, fn: Callable[..., T], *args: object
    ) -> asyncio.Future[T]:
        """Queue `fn(*args)` for the thread; the future on `loop` it resolves."""
        fut: asyncio.Future[T] = loop.create_future()
        self._jobs.put((loop, fut, fn, args))
        return fut

    def shutdown(self, timeout_s: float) -> bool:
        """Let the step under way end, for at most `timeout_s`; whether the thread ended."""
        self._jobs.put(None)
        self._thread.join(timeout_s)
        return not self._thread.is_alive()

    def _run(self) -> None:
        priority.restore(self._nice)
        while True:
            job = self._jobs.get()
            if job is None:
                return
            loop, fut, fn, args = job
            try:
                result, error = fn(*args), None
            except BaseException as exc:  # handed to the awaiting loop
                result, error = None, exc
            with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
                loop.call_soon_threadsafe(_settle, fut, result, error)


# Any: as in _Job, the Future of a job of any result type
def _settle(fut: asyncio.Future[Any], result: object, error: BaseException | None) -> None:
    if fut.done():  # cancelled by a loop that stopped waiting
        return
    if error is not None:
        fut.set_exception(error)
    else:
        fut.set_result(result)
