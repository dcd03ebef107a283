"""One writer's calls sent to two: the recording first, then a viewer (`sweep --live`).

The second must not block or raise (live/publisher.py only queues); the recording is
always written first, so what a viewer does cannot come before or instead of it.
"""

from __future__ import annotations

from shockdyno.record.types import TestMeta
from shockdyno.run.sweep import Writer
from shockdyno.samples import SampleBlock


class Fanout:
    """A Writer that passes every call to the recording first, then to the viewer."""

    def __init__(self, recording: Writer, viewer: Writer) -> None:
        self.recording = recording
        self.viewer = viewer

    def begin_test(self, meta: TestMeta) -> None:
        """`begin_test` on the recording, then on the viewer."""
        self.recording.begin_test(meta)
        self.viewer.begin_test(meta)

    def write_samples(self, block: SampleBlock) -> None:
        """`write_samples` on the recording, then on the viewer."""
        self.recording.write_samples(block)
        self.viewer.write_samples(block)

    def write_actuator(self, t_s: float, fields: dict[str, float | int | bool | str]) -> None:
        """`write_actuator` on the recording, then on the viewer."""
        self.recording.write_actuator(t_s, fields)
        self.viewer.write_actuator(t_s, fields)

    def write_event(self, t_s: float, kind: str, message: str) -> None:
        """`write_event` on the recording, then on the viewer."""
        self.recording.write_event(t_s, kind, message)
        self.viewer.write_event(t_s, kind, message)

    def end_test(self, meta: TestMeta) -> None:
        """`end_test` on the recording, then on the viewer."""
        self.recording.end_test(meta)
        self.viewer.end_test(meta)
