"""The session's heartbeat and event log on their own (the contract suites drive them
through a whole session on the simulated rig)."""

from __future__ import annotations

import pytest

from shockdyno.errors import RigFault
from shockdyno.run.events import EventLog
from shockdyno.run.heartbeat import LoopHeartbeat
from shockdyno.run.safety import SafetyEvent


def test_the_heartbeat_beats_only_when_the_loop_feeds_it() -> None:
    """No thread of its own: no feed, no beat, however long it waits (issue 46.1)."""
    now = [0.0]
    beats: list[float] = []
    fail: list[str] = []

    def beat() -> None:
        if fail:
            raise RigFault(fail[0])
        beats.append(now[0])

    hb = LoopHeartbeat(beat, period_s=0.1, clock=lambda: now[0])
    hb.feed()
    assert beats == []  # not started: a disabled drive needs no beats
    hb.start()
    assert beats == [0.0]  # a beat at once
    for t in (0.05, 0.1, 0.15, 0.2, 0.95, 1.0):
        now[0] = t
        hb.feed()
    assert beats == [0.0, 0.1, 0.2, 0.95]  # a period apart, and only when fed
    assert hb.worst_gap_s == pytest.approx(0.75)  # the loop was away 0.75 s
    fail.append("timeout")
    now[0] = 2.0
    with pytest.raises(RigFault, match="timeout"):
        hb.feed()  # the loop that feeds it hears of a failed beat
    fail.clear()
    hb.feed()  # tried again at the next feed
    assert beats[-1] == 2.0 and hb.beats == 5
    hb.stop()
    now[0] = 5.0
    hb.feed()
    assert beats[-1] == 2.0
    assert "longest gap between two 1050 ms" in hb.describe(1.0)


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
