"""The drive's watchdog fed from a thread of its own.

The drive disables itself when no heartbeat arrives within its watchdog time, so a host
that hangs or dies leaves the ram stopped. A beat that fails is remembered, never raised
in the thread: the session trips on `error` at its next sample ("lost link").
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from shockdyno.errors import RigFault


class Heartbeat:
    def __init__(self, beat: Callable[[], None], period_s: float) -> None:
        self._beat = beat
        self._period_s = period_s
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.error: str | None = None  # why the beats stopped, once one failed

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> None:
        """Beat every period until `stop` (a running heartbeat goes on as it is)."""
        if self.running:
            return
        self._stop.clear()
        self.error = None

        def run() -> None:
            while not self._stop.is_set():
                try:
                    self._beat()
                except RigFault as exc:
                    self.error = f"lost link to actuator (heartbeat): {exc}"
                    return
                self._stop.wait(self._period_s)

        self._thread = threading.Thread(target=run, name="rig-heartbeat", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5)
            self._thread = None
