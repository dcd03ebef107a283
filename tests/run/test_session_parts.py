"""The session's heartbeat and event log on their own (the contract suites drive them
through a whole session on the simulated rig)."""

from __future__ import annotations

import threading

from shockdyno.errors import RigFault
from shockdyno.run.events import EventLog
from shockdyno.run.heartbeat import Heartbeat
from shockdyno.run.safety import SafetyEvent


def test_the_heartbeat_beats_until_stopped_and_remembers_a_lost_link() -> None:
    beats = threading.Semaphore(0)
    fail = threading.Event()

    def beat() -> None:
        if fail.is_set():
            raise RigFault("timeout")
        beats.release()

    hb = Heartbeat(beat, period_s=0.001)
    hb.start()
    assert all(beats.acquire(timeout=5) for _ in range(3))  # it beats on its own
    assert hb.error is None and hb.running
    fail.set()
    hb._thread.join(5)  # type: ignore[union-attr]  # the thread ends at the failed beat
    assert not hb.running
    assert hb.error == "lost link to actuator (heartbeat): timeout"
    fail.clear()
    hb.start()  # a new start clears the error and beats again
    assert hb.error is None and beats.acquire(timeout=5)
    hb.stop()
    assert not hb.running


def test_the_log_sends_each_event_and_survives_a_sink_that_fails() -> None:
    sent: list[tuple[float, str, str]] = []
    log = EventLog(lambda: 7.5)
    log.record(SafetyEvent(1.0, "connect", "before the sink"))
    log.attach(lambda t, k, m: sent.append((t, k, m)))
    assert sent == [(1.0, "connect", "before the sink")]  # earlier events are sent on attach
    log.record(SafetyEvent(2.0, "enable", "on"))
    assert sent[-1] == (2.0, "enable", "on")

    def full_disk(t: float, k: str, m: str) -> None:
        raise OSError("no space left on device")

    log.attach(full_disk)  # resends the two, fails on the first
    log.record(SafetyEvent(3.0, "disable", "off"))  # kept, and no exception
    kinds = [e.kind for e in log.events]
    assert kinds == ["connect", "enable", "record_failed", "disable"]
    failed = log.events[2]
    assert failed.t_s == 7.5 and "no space left on device" in failed.message
