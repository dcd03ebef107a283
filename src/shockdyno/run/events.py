"""The session's safety events: kept in order and, once a sink is attached (the
recording's write_event), each sent to it as it happens, so a crash cannot lose the
events before it. A sink that fails is dropped and the failure logged as an event of its
own: a full disk must not stop the stop sequence."""

from __future__ import annotations

from collections.abc import Callable

from shockdyno.run.safety import SafetyEvent

EventSink = Callable[[float, str, str], None]


class EventLog:
    """The session's safety events in order, each sent to the attached sink (the recording) as it
    happens."""

    def __init__(self, now: Callable[[], float]) -> None:
        self.events: list[SafetyEvent] = []
        self._now = now  # the session's DAQ time, for the events the log itself writes
        self._sink: EventSink | None = None

    def attach(self, sink: EventSink | None) -> None:
        """Send every event so far, then each one as it happens, to `sink` (None: stop)."""
        self._sink = sink
        for ev in self.events:
            self._send(ev)

    def _send(self, ev: SafetyEvent) -> None:
        if self._sink is None:
            return
        try:
            self._sink(ev.t_s, ev.kind, ev.message)
        except Exception as exc:  # a full disk must not stop the stop sequence; keep it here
            self._sink = None
            self.events.append(
                SafetyEvent(self._now(), "record_failed", f"events not recorded: {exc}")
            )

    def record(self, ev: SafetyEvent) -> SafetyEvent:
        """Keep the event and send it to the sink; returns it."""
        self.events.append(ev)
        self._send(ev)
        return ev

    def note(self, kind: str, message: str) -> SafetyEvent:
        """Record an event at the session's DAQ time now."""
        return self.record(SafetyEvent(self._now(), kind, message))
