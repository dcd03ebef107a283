"""SIGINT, SIGTERM and SIGHUP all end a session the same way: a controlled stop.

A closed terminal (SIGHUP), `timeout`, `kill` or `systemctl stop` (SIGTERM) must leave the
ram stopped, centred and disabled and the recording closed, exactly like Ctrl-C. The first
signal raises in the main thread (KeyboardInterrupt for SIGINT, `Terminated` for the
others), which unwinds through the sweep's own teardown. Later signals are only noted: a
second Ctrl-C 0.1 s after the first must not cut the stop sequence it started short.
While the teardown runs (`hold()`), even the first signal waits until the ram is safe.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class Terminated(KeyboardInterrupt):
    """The process was asked to end by a signal other than SIGINT."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        super().__init__(signal.Signals(signum).name)


class _State:
    received: list[int]
    raised = False
    held = 0
    installed = False

    def __init__(self) -> None:
        self.received = []


_state = _State()


def _exception(signum: int) -> KeyboardInterrupt:
    return KeyboardInterrupt() if signum == signal.SIGINT else Terminated(signum)


def _handler(signum: int, frame: FrameType | None) -> None:
    _state.received.append(signum)
    if not _state.raised and _state.held == 0:
        _state.raised = True
        raise _exception(signum)


def received() -> list[str]:
    """Names of the stop signals received so far (in order)."""
    return [signal.Signals(s).name for s in _state.received]


@contextmanager
def stop_on_signals() -> Iterator[None]:
    """Install the handlers for the duration of a session (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    _state.received.clear()
    _state.raised = False
    _state.installed = True
    for s in STOP_SIGNALS:
        signal.signal(s, _handler)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
        _state.installed = False


@contextmanager
def hold() -> Iterator[None]:
    """Let a stop sequence finish; a first signal that arrived meanwhile is raised after."""
    _state.held += 1
    try:
        yield
    finally:
        _state.held -= 1
    if _state.installed and _state.held == 0 and _state.received and not _state.raised:
        _state.raised = True
        raise _exception(_state.received[0])


def describe(exc: BaseException) -> str | None:
    """The operator-facing reason for a signal's exception, else None."""
    if isinstance(exc, Terminated):
        name = signal.Signals(exc.signum).name
        why = "terminal closed" if exc.signum == signal.SIGHUP else "asked to terminate"
        return f"{name} received ({why})"
    if isinstance(exc, KeyboardInterrupt):
        return "operator interrupt (Ctrl-C)"
    return None
