"""CPU priority of the threads a busy shop PC must not starve: the session's control loop
(it feeds the drive's watchdog and checks the limits) and a simulated rig's drive (a real
drive has a processor of its own).

`raised()` lowers the calling thread's nice value (Linux keeps one per thread) for the
duration of a session and restores it after; threads started meanwhile inherit it, those
started before (a recording's writer, a simulated rig) keep theirs. A process without the
right to raise it (CAP_SYS_NICE, or an RLIMIT_NICE in /etc/security/limits.conf such as
`@dyno - nice -10`) runs at its normal priority and says so: the session goes on, with
the watchdog's budget as the only guarantee (docs/safety.md, "A busy host").
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from contextlib import contextmanager

CONTROL_NICE = -10  # the control loop: well above a shop PC's normal work, below real time


def _get() -> int | None:
    try:
        return os.getpriority(os.PRIO_PROCESS, 0)
    except (AttributeError, OSError):
        return None


def raise_priority(nice: int = CONTROL_NICE) -> tuple[int | None, str]:
    """Lower this thread's nice value to `nice` if it is higher: (the value before, what
    happened in words)."""
    before = _get()
    if before is None:
        return None, "priority: not adjustable on this system"
    if before <= nice:
        return None, f"priority: nice {before} already"
    try:
        os.setpriority(os.PRIO_PROCESS, 0, nice)
    except OSError:
        return None, (
            f"priority: normal (nice {before}); raising it to {nice} is not permitted "
            "(CAP_SYS_NICE or a nice limit in limits.conf)"
        )
    return before, f"priority: nice {nice} (was {before})"


def restore(before: int | None) -> None:
    if before is None:
        return
    with contextlib.suppress(OSError):  # raising the value back is always allowed
        os.setpriority(os.PRIO_PROCESS, 0, before)


@contextmanager
def raised(nice: int = CONTROL_NICE) -> Iterator[str]:
    before, said = raise_priority(nice)
    try:
        yield said
    finally:
        restore(before)
