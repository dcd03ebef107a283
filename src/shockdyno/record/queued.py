"""A recording written by a thread of its own, so that the control loop never waits on a
file.

A sweep's control loop reads the DAQ, checks the limits and feeds the drive's watchdog;
writing and fsyncing the recording (a chunk, a test's end, each event) can take a slow
disk a second, and with the watchdog fed by that loop a second without a beat stops the
drive. So the loop only queues each write; this thread does them, in order.

The queue is bounded by samples (`max_pending_samples`): a disk that cannot keep up is
an error at the next write, which stops the test, never a memory that grows with it or a
loop that blocks. An error in the thread (a full disk) is raised at the next call, once.
What is queued reaches the disk within the thread's next turn: a kill -9 can lose the last
few milliseconds that a direct write would have kept (`close` and `flush` wait for all).
"""

from __future__ import annotations

import contextlib
import threading
from collections import deque
from collections.abc import Callable
from pathlib import Path
from types import TracebackType

from shockdyno import priority
from shockdyno.errors import RecordingError
from shockdyno.record.types import TestMeta
from shockdyno.record.writer import RecordingWriter
from shockdyno.samples import SampleBlock

MAX_PENDING_SAMPLES = 1_000_000  # ~42 MB of SampleBlocks; 1000 s of a 1 kHz DAQ


class QueuedWriter:
    """A RecordingWriter driven from a thread of its own: each call only queues (bounded by
    samples), so the control loop never waits on the disk; a writer error is raised at the next
    call."""

    def __init__(
        self, writer: RecordingWriter, max_pending_samples: int = MAX_PENDING_SAMPLES
    ) -> None:
        self.writer = writer
        self.max_pending_samples = max_pending_samples
        self._queue: deque[tuple[Callable[..., object], tuple[object, ...], int] | None] = deque()
        self._cv = threading.Condition()
        self._pending = 0  # samples queued and not yet written
        self._busy = False
        self._error: BaseException | None = None
        self._raised = False
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="recording-writer", daemon=True)
        self._thread.start()

    @property
    def path(self) -> Path:
        """The recording's path."""
        return self.writer.path

    # -- the writer's API, queued ------------------------------------------------------
    def begin_test(self, meta: TestMeta) -> None:
        """Queue the writer's `begin_test` (RecordingError for a failure the thread met since the
        last call, or once closed)."""
        self._put(self.writer.begin_test, meta)

    def write_samples(self, block: SampleBlock) -> None:
        """Queue the writer's `write_samples` (an empty block: nothing); RecordingError when the
        disk falls `max_pending_samples` behind."""
        if len(block):
            self._put(self.writer.write_samples, block, samples=len(block))

    def write_actuator(self, t_s: float, fields: dict[str, float | int | bool | str]) -> None:
        """Queue the writer's `write_actuator` (the fields copied)."""
        self._put(self.writer.write_actuator, t_s, dict(fields))

    def write_event(self, t_s: float, kind: str, message: str) -> None:
        """Queue the writer's `write_event`."""
        self._put(self.writer.write_event, t_s, kind, message)

    def end_test(self, meta: TestMeta) -> None:
        """Queue the writer's `end_test`."""
        self._put(self.writer.end_test, meta)

    def flush(self) -> None:
        """Wait until everything queued is written (raises the thread's error, if any)."""
        with self._cv:
            self._cv.wait_for(lambda: not self._queue and not self._busy)
        self._raise()

    def close(self) -> None:
        """Write what is queued, close the file, end the thread (idempotent)."""
        if self._closed:
            return
        self._closed = True
        with self._cv:
            self._queue.append((self.writer.close, (), 0))
            self._queue.append(None)
            self._cv.notify_all()
        self._thread.join()
        if self._error is not None:
            with contextlib.suppress(Exception):  # after an error the file is still closed
                self.writer.close()
        self._raise()

    def discard(self) -> None:
        """Close and remove a file in which no test began (record/writer.py)."""
        self.close()
        self.writer.discard()

    def __enter__(self) -> QueuedWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- the thread ----------------------------------------------------------------------
    def _put(self, fn: Callable[..., object], *args: object, samples: int = 0) -> None:
        self._raise()
        if self._closed:
            raise RecordingError(f"{self.path} is closed")
        with self._cv:
            if samples and self._pending + samples > self.max_pending_samples:
                raise RecordingError(
                    f"the recording {self.path} does not keep up with the DAQ: "
                    f"{self._pending} samples wait for the disk"
                )
            self._pending += samples
            self._queue.append((fn, args, samples))
            self._cv.notify_all()

    def _raise(self) -> None:
        if self._error is not None and not self._raised:
            self._raised = True
            err = self._error
            if isinstance(err, RecordingError):
                raise RecordingError(str(err)) from None
            raise RecordingError(f"cannot write {self.path} ({err})") from None

    def _run(self) -> None:
        # As urgent as the control loop: a writer that holds the interpreter's lock and is
        # preempted by a busy host's other work would hold the loop up with it.
        priority.raise_priority()
        while True:
            with self._cv:
                self._cv.wait_for(lambda: bool(self._queue))
                item = self._queue.popleft()
                if item is None:
                    self._cv.notify_all()
                    return
                self._busy = True
            fn, args, samples = item
            try:
                if self._error is None:
                    fn(*args)
            except BaseException as exc:  # kept for the control loop's next call
                self._error = exc
            finally:
                with self._cv:
                    self._pending -= samples
                    self._busy = False
                    self._cv.notify_all()
