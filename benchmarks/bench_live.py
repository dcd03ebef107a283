"""What `sweep --live` costs the control loop, and how fast the live view sends.

1. Per call on the control loop's thread: `LivePublisher.write_samples` of a 50-sample
   block (a 20 Hz DAQ poll at 1 kHz), against the baseline the loop already pays for
   the same block: the recording's `QueuedWriter.write_samples` (same run).
2. The live view's thread: samples per second encoded (CDR samples, the plan, cycles)
   and sent to one subscribed Foxglove WebSocket client, against the 1 kHz need.
3. The loop's lateness: a thread that sleeps 1 ms and writes a block, 3000 times, with
   the live view idle (no client) and busy (a client subscribed to every channel):
   the worst and 99th-percentile oversleep, ratio busy/idle.

    .venv/bin/python benchmarks/bench_live.py
"""

from __future__ import annotations

import asyncio
import json
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from shockdyno.live.publisher import LivePublisher
from shockdyno.live.server import LiveServer
from shockdyno.record.queued import QueuedWriter
from shockdyno.record.types import TestMeta
from shockdyno.record.writer import RecordingWriter
from shockdyno.rig.frames import STATUS_MOTION
from shockdyno.samples import SampleBlock

BLOCK = 50
CALLS = 20_000
META = TestMeta(index=0, clicks=0, gas_clicks=0, frequency_hz=1.0, amplitude_m=0.03,
                sample_rate_hz=1000.0, warmup_cycles=1000, measured_cycles=1000)  # fmt: skip


def blocks(n: int) -> list[SampleBlock]:
    out = []
    for i in range(n):
        seq = np.arange(i * BLOCK, (i + 1) * BLOCK, dtype=np.int64)
        t = seq / 1000.0
        x = 0.03 * np.sin(2 * np.pi * t)
        status = np.full(BLOCK, STATUS_MOTION, np.uint16)
        out.append(SampleBlock(seq, t, x, 1e4 * x, np.full(BLOCK, 40.0), status))
    return out


def per_call(write: object, data: list[SampleBlock]) -> tuple[float, float]:
    times = np.empty(len(data))
    for i, b in enumerate(data):
        t = time.perf_counter()
        write(b)  # type: ignore[operator]
        times[i] = time.perf_counter() - t
    return float(np.median(times)), float(np.percentile(times, 99))


def subscribe(url: str) -> threading.Event:
    """A real client subscribed to every channel, reading (and discarding) all it gets."""
    import websockets

    ready = threading.Event()

    async def main() -> None:
        async with websockets.connect(url, subprotocols=["foxglove.sdk.v1"]) as ws:  # type: ignore[list-item]
            async for frame in ws:
                if isinstance(frame, str) and json.loads(frame)["op"] == "advertise":
                    subs = [{"id": c["id"], "channelId": c["id"]}
                            for c in json.loads(frame)["channels"]]  # fmt: skip
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                    await asyncio.sleep(0.3)
                    ready.set()

    threading.Thread(target=lambda: asyncio.run(main()), daemon=True).start()
    ready.wait(10)
    return ready


def lateness(write: object, n: int = 3000) -> tuple[float, float]:
    data = blocks(n)
    late = np.empty(n)
    for i in range(n):
        t = time.perf_counter()
        time.sleep(0.001)
        late[i] = time.perf_counter() - t - 0.001
        write(data[i])  # type: ignore[operator]
    return float(late.max()), float(np.percentile(late, 99))


def main() -> None:
    data = blocks(CALLS)
    with tempfile.TemporaryDirectory() as folder:
        queued = QueuedWriter(RecordingWriter(Path(folder) / "b.mcap", metadata={}))
        queued.begin_test(META)
        base_med, base_p99 = per_call(queued.write_samples, data)
        queued.close()

    server = LiveServer("127.0.0.1", 0)
    live = LivePublisher(server, warn=print, max_samples=10**9)
    live.begin_test(META)
    med, p99 = per_call(live.write_samples, data)
    live.close(drain_s=60)
    print(f"1. per call of {BLOCK} samples on the loop's thread (median, p99):")
    print(f"   recording QueuedWriter (baseline)  {base_med * 1e6:7.1f} µs"
          f" {base_p99 * 1e6:7.1f} µs")  # fmt: skip
    print(f"   LivePublisher                      {med * 1e6:7.1f} µs {p99 * 1e6:7.1f} µs"
          f"   x{med / base_med:.2f} of the baseline")  # fmt: skip

    server = LiveServer("127.0.0.1", 0)
    subscribe(server.url)
    live = LivePublisher(server, warn=print, blocking=True)
    live.begin_test(META)
    t = time.perf_counter()
    for b in data:
        live.write_samples(b)
    while live._queue:
        time.sleep(0.001)
    took = time.perf_counter() - t
    rate = CALLS * BLOCK / took
    live.close()
    print(f"2. live view thread, one client on every channel: {rate:,.0f} samples/s "
          f"= x{rate / 1000:.0f} the 1 kHz need ({live.counts.messages} messages)")  # fmt: skip

    server = LiveServer("127.0.0.1", 0)
    live = LivePublisher(server, warn=print)
    live.begin_test(META)
    idle_max, idle_p99 = lateness(live.write_samples)
    live.close()
    server = LiveServer("127.0.0.1", 0)
    subscribe(server.url)
    live = LivePublisher(server, warn=print)
    live.begin_test(META)
    busy_max, busy_p99 = lateness(live.write_samples)
    live.close()
    print("3. a 1 ms loop's oversleep (max, p99):")
    print(f"   live view idle (no client)        {idle_max * 1e3:6.2f} ms"
          f" {idle_p99 * 1e3:6.2f} ms")  # fmt: skip
    print(f"   live view busy (client, all)      {busy_max * 1e3:6.2f} ms {busy_p99 * 1e3:6.2f} ms"
          f"   p99 x{busy_p99 / idle_p99:.2f}")  # fmt: skip
    print(f"   ({live.summary()})")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
