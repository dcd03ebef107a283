"""The drive's watchdog as a proof of life of the control loop.

The drive disables itself when no heartbeat arrives within its watchdog time. The beat is
written by the loop that reads the DAQ's samples and checks the limits (`ControlLoop.pump`),
never by a thread of its own: a thread that beats on its own keeps the drive enabled while
the main thread is blocked (an operator prompt, a file that never opens) and nothing
watches the ram. So when the loop stops, the beats stop, and the drive stops the ram in
its watchdog time.

`feed` is called after every read; it beats once a period has passed since the last beat.
The longest time between two beats is kept: how close the loop came to the watchdog
(`worst_gap_s`, recorded when the session ends and printed by benchmarks/bench_faults.py).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable


class LoopHeartbeat:
    """The drive's watchdog fed by the control loop itself: `feed` after every DAQ read beats
    once a period has passed; counts the beats and the longest gap between two (s)."""

    def __init__(
        self,
        beat: Callable[[], None],
        period_s: float,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._beat = beat
        self.period_s = period_s
        self._clock = clock
        self._last = -math.inf
        self.active = False
        self.beats = 0
        self.worst_gap_s = 0.0

    def start(self) -> None:
        """Beat now and from now on at every `feed` a period after the last beat."""
        self.active = True
        self._last = -math.inf
        self.feed()

    def stop(self) -> None:
        """Stop beating at `feed` (the drive's watchdog then stops the ram unless disabled
        first)."""
        self.active = False

    def feed(self) -> None:
        """Beat if a period has passed since the last beat (a failed beat raises RigFault
        and is tried again at the next feed)."""
        if not self.active:
            return
        now = self._clock()
        if now - self._last < self.period_s:
            return
        self._beat()
        if math.isfinite(self._last):
            self.worst_gap_s = max(self.worst_gap_s, now - self._last)
        self._last = now
        self.beats += 1

    def describe(self, watchdog_s: float) -> str:
        """One line: the beats sent and the longest gap between two against the drive's watchdog
        (ms)."""
        return (
            f"control loop: {self.beats} heartbeats, longest gap between two "
            f"{self.worst_gap_s * 1e3:.0f} ms (drive watchdog {watchdog_s * 1e3:.0f} ms)"
        )
