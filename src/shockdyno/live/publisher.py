"""The live view's side of a sweep: the recording's writer calls, sent to Foxglove by a
thread of its own, so the control loop never waits on a viewer.

The sweep calls `begin_test`, `write_samples`, `write_actuator`, `write_event` and
`end_test` exactly as on its recording (run/sweep.py `Writer`). Each call only appends to
a queue (no lock, no encoding, nothing that can block or raise), bounded by
`max_samples` queued samples and `max_items` queued calls: past either, the call is
dropped and counted. The thread encodes (the recording's CDR samples and JSON records,
record/schemas.py; the plan and the cycles, cycles.py) and hands each message to the
server, which keeps a bounded backlog per client and drops a slow client's oldest data
itself (foxglove-sdk). A failure in the thread (a server that stopped, a bug) is one
warning and the end of the live view; the sweep goes on.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import SupportsFloat, cast

import msgspec
import numpy as np
from numpy.typing import ArrayLike

from shockdyno.live.cycles import Cycle, CycleCutter, FloatArray, Stretch
from shockdyno.live.server import TOPIC_CYCLE, TOPIC_POSITION, LiveServer
from shockdyno.record import schemas as s
from shockdyno.record.types import TestMeta
from shockdyno.samples import SampleBlock

MAX_SAMPLES = 60_000  # a minute of a 1 kHz DAQ waiting for the thread
MAX_ITEMS = 20_000
IDLE_S = 0.02  # the thread's nap when the queue is empty: the viewer's latency, not the loop's


@dataclass
class LiveCounts:
    """What was sent and what was not. Each field has one writer: the caller's thread
    (refused: the queue was full, or the view had failed) or the live view's (lost)."""

    messages: int = 0  # messages handed to the server
    samples: int = 0  # samples the thread took from the queue and sent on
    refused_samples: int = 0
    refused_calls: int = 0  # test records, actuator records, events
    lost_samples: int = 0
    lost_calls: int = 0

    @property
    def dropped_samples(self) -> int:
        """Samples that never reached the server: refused at the queue, or lost when the view
        failed."""
        return self.refused_samples + self.lost_samples

    @property
    def dropped_calls(self) -> int:
        """Test records, actuator records and events that never reached the server."""
        return self.refused_calls + self.lost_calls


class LivePublisher:
    """The recording's writer calls sent to a Foxglove server by a thread of its own: each call
    only queues (bounded; past the bound it is dropped and counted), so the control loop never
    waits on a viewer."""

    def __init__(
        self,
        server: LiveServer,
        warn: Callable[[str], None],
        *,
        max_samples: int = MAX_SAMPLES,
        max_items: int = MAX_ITEMS,
        blocking: bool = False,
    ) -> None:
        """`blocking`: a full queue makes the caller wait instead of dropping; only for a
        caller that drives no rig (`replay --live`)."""
        self.server = server
        self.counts = LiveCounts()
        self._warn = warn
        self._max_samples = max_samples
        self._max_items = max_items
        self._blocking = blocking
        # (operation, its arguments): each `_on_<operation>`'s own, in one queue
        self._queue: deque[tuple[str, tuple[object, ...]]] = deque()
        # Each counter is written by one thread only: queued by the caller, sent by the thread.
        self._queued_samples = 0
        self._sent_samples = 0
        self._failed = False
        self._stop = threading.Event()
        self._origin_ns: int | None = None  # wall clock of t_s = 0, as the recording's
        self._serial = -1
        self._open: TestMeta | None = None
        self._count = 0
        self._last_t = 0.0
        self._cutter = CycleCutter()
        self._said_dropped = 0  # dropped samples the viewers were told of
        self._said_at = -math.inf
        self._thread = threading.Thread(target=self._run, name="live-view", daemon=True)
        self._thread.start()

    # -- the recording's API, queued (the control loop's thread) ---------------------------
    def begin_test(self, meta: TestMeta) -> None:
        """Queue a test's begin record (dropped and counted when the queue is full)."""
        self._put("begin", (meta,))

    def write_samples(self, block: SampleBlock) -> None:
        """Queue a block of samples (dropped and counted past `max_samples` waiting, unless
        `blocking`)."""
        n = len(block)
        if not n:
            return
        if self._origin_ns is None:
            self._origin_ns = time.time_ns() - round(float(block.t_s[0]) * 1e9)
        while self._blocking and not self._failed and self._backlog(n):
            time.sleep(IDLE_S)
        if self._failed or self._backlog(n):
            self.counts.refused_samples += n
            return
        self._queued_samples += n
        self._put("samples", (block,))

    def write_actuator(self, t_s: float, fields: dict[str, float | int | bool | str]) -> None:
        """Queue an actuator record (dropped and counted when the queue is full)."""
        self._put("actuator", (t_s, dict(fields)))

    def write_event(self, t_s: float, kind: str, message: str) -> None:
        """Queue a session event (dropped and counted when the queue is full)."""
        self._put("event", (t_s, kind, message))

    def end_test(self, meta: TestMeta) -> None:
        """Queue a test's end record (dropped and counted when the queue is full)."""
        self._put("end", (meta,))

    def _backlog(self, n: int) -> bool:
        """n more samples would be more than the queue holds."""
        return self._queued_samples - self._sent_samples + n > self._max_samples

    def _put(self, op: str, args: tuple[object, ...]) -> None:
        if op != "samples" and (self._failed or len(self._queue) >= self._max_items):
            self.counts.refused_calls += 1
            return
        self._queue.append((op, args))

    # -- teardown ------------------------------------------------------------------------
    def close(self, drain_s: float = 2.0) -> None:
        """Send what is queued (for at most `drain_s`), then stop the thread and the server."""
        deadline = time.monotonic() + drain_s
        while self._queue and not self._failed and time.monotonic() < deadline:
            time.sleep(IDLE_S)
        self._stop.set()
        self._thread.join(timeout=drain_s)
        for op, args in list(self._queue):
            self._drop(op, args)
        self._queue.clear()
        self.server.stop()

    def summary(self) -> str:
        """One line at the end: messages sent and what was dropped."""
        c = self.counts
        said = f"live view closed: {c.messages} messages sent"
        if c.dropped_samples or c.dropped_calls:
            said += (
                f", {c.dropped_samples} samples and {c.dropped_calls} records dropped "
                "(the viewer fell behind; the recording has them all)"
            )
        return said

    # -- the thread ----------------------------------------------------------------------
    def _drop(self, op: str, args: tuple[object, ...]) -> None:
        if op == "samples":
            n = len(cast(SampleBlock, args[0]))  # write_samples queued it
            self.counts.lost_samples += n
            self._sent_samples += n
        else:
            self.counts.lost_calls += 1

    def _say_drops(self) -> None:
        """Tell the viewers when samples were dropped since the last time (at most once a
        second): what they see has gaps the recording does not."""
        now = time.monotonic()
        dropped = self.counts.dropped_samples
        if dropped > self._said_dropped and now - self._said_at >= 1.0:
            self._said_dropped, self._said_at = dropped, now
            self.server.warn(
                f"live view: {dropped} samples dropped so far (the live view fell behind; "
                "the recording has them all)"
            )

    def _run(self) -> None:
        while True:
            if not self._failed:
                try:
                    self._say_drops()
                except Exception:  # a warning that cannot be sent is not worth another
                    self._said_at = math.inf
            try:
                op, args = self._queue.popleft()
            except IndexError:
                if self._stop.is_set():
                    return
                self._stop.wait(IDLE_S)
                continue
            if self._failed:
                self._drop(op, args)
                continue
            try:
                getattr(self, f"_on_{op}")(*args)
            except Exception as exc:  # the live view ends; the sweep and its recording go on
                self._failed = True
                self._drop(op, args)
                self._warn(f"live view stopped ({type(exc).__name__}: {exc}); the sweep goes on")

    def _log_time(self, t_s: float) -> int:
        if self._origin_ns is None:
            return time.time_ns()
        return self._origin_ns + round(t_s * 1e9)

    def _send_json(self, topic: str, t_s: float, obj: Mapping[str, object]) -> None:
        if self.server.watched(topic):
            data = _JSON.encode(obj)
            self.server.send(topic, self._log_time(t_s), data)
            self.counts.messages += 1

    @property
    def _test_field(self) -> int | None:
        return self._serial if self._open is not None else None

    def _on_begin(self, meta: TestMeta) -> None:
        self._serial += 1
        self._open = meta
        self._count = 0
        self._cutter.begin(meta)
        record = {"phase": "begin", "test": self._serial, "t_s": self._last_t}
        self._send_json(s.TOPIC_TEST, self._last_t, {**record, **s.meta_to_json(meta)})

    def _on_end(self, meta: TestMeta) -> None:
        record = {"phase": "end", "test": self._serial, "t_s": self._last_t}
        record["sample_count"] = self._count
        self._send_json(s.TOPIC_TEST, self._last_t, {**record, **s.meta_to_json(meta)})
        self._open = None
        self._cutter.end()

    def _on_actuator(self, t_s: float, fields: dict[str, float | int | bool | str]) -> None:
        self._cutter.actuator(fields)
        obj: dict[str, object] = {"t_s": float(t_s), "test": self._test_field}
        for k, v in fields.items():
            obj.setdefault(k, str(v) if isinstance(v, float) and not np.isfinite(v) else v)
        self._send_json(s.TOPIC_ACTUATOR, t_s, obj)

    def _on_event(self, t_s: float, kind: str, message: str) -> None:
        obj = {"t_s": float(t_s), "test": self._test_field, "kind": kind, "message": message}
        self._send_json(s.TOPIC_EVENTS, t_s, obj)

    def _on_samples(self, block: SampleBlock) -> None:
        n = len(block)
        self._sent_samples += n
        self.counts.samples += n
        if self._open is not None:
            self._count += n
        self._last_t = float(block.t_s[-1])
        stretch, cycles = self._cutter.feed(block)
        t0 = float(block.t_s[0])
        if self.server.watched(s.TOPIC_SAMPLES):
            test = self._serial if self._open is not None else s.NO_TEST
            data = s.encode_samples(test, block, stretch.velocity_m_s)
            self.server.send(s.TOPIC_SAMPLES, self._log_time(t0), data)
            self.counts.messages += 1
        self._send_json(TOPIC_POSITION, t0, _position(self._test_field, stretch))
        for cycle in cycles:
            self._send_json(TOPIC_CYCLE, cycle.t_start_s, self._cycle(cycle))

    def _cycle(self, c: Cycle) -> dict[str, object]:
        m = self._open
        assert m is not None
        f, v = c.force_n, c.velocity_m_s
        return {
            "test": self._serial,
            "index": m.index,
            "clicks": m.clicks,
            "gas_clicks": m.gas_clicks,
            "frequency_hz": m.frequency_hz,
            "amplitude_m": m.amplitude_m,
            "cycle": c.index,
            "part": c.part,
            "t_start_s": c.t_start_s,
            "t_s": _list(c.t_s),
            "displacement_m": _list(c.displacement_m),
            "velocity_m_s": _list(v),
            "force_n": _list(f),
            "commanded_m": _list(c.commanded_m) if c.commanded_m is not None else [],
            "peak_compression_force_n": _peak(f, np.max),
            "peak_rebound_force_n": _peak(f, np.min),
            "peak_velocity_m_s": _peak(np.abs(v), np.max),
        }


def _list(a: ArrayLike) -> list[float]:
    """JSON numbers (msgspec writes NaN, a velocity that cannot be had, as null)."""
    return list(np.asarray(a, dtype=float).tolist())


def _peak(a: FloatArray, pick: Callable[[FloatArray], SupportsFloat]) -> float | None:
    finite = a[np.isfinite(a)]
    return float(pick(finite)) if finite.size else None


def _position(test: int | None, st: Stretch) -> dict[str, object]:
    obj: dict[str, object] = {
        "test": test,
        "t_s": _list(st.t_s),
        "displacement_m": _list(st.displacement_m),
        "force_n": _list(st.force_n),
    }
    if st.commanded_m is not None:
        obj["commanded_m"] = _list(st.commanded_m)
        obj["error_m"] = _list(st.displacement_m - st.commanded_m)
    return obj


def _plain(v: object) -> object:
    if isinstance(v, np.generic):
        return v.item()
    raise NotImplementedError(f"{type(v).__name__} is not JSON")


# C speed: the thread holds the interpreter's lock, which the control loop also needs,
# for as short a time as it can.
_JSON = msgspec.json.Encoder(enc_hook=_plain)
