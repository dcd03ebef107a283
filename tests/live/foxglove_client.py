"""A small, real Foxglove WebSocket client (the `websockets` package), as the Foxglove app
talks to a server: it offers the subprotocol, reads serverInfo and advertise, subscribes
to every channel, and keeps each binary messageData frame (opcode 0x01, subscription id
u32 LE, log time u64 LE, payload) until the server closes the connection.

foxglove-sdk's server speaks protocol v1 under the subprotocol name `foxglove.sdk.v1`
(the same messages as `foxglove.websocket.v1`, which it refuses with HTTP 400); the
Foxglove app offers both."""

from __future__ import annotations

import asyncio
import json
import struct
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import websockets

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
_HEAD = struct.Struct("<BIQ")


@dataclass
class Received:
    subprotocol: str | None = None
    server_info: dict[str, Any] = field(default_factory=dict)
    channels: dict[int, dict[str, Any]] = field(default_factory=dict)  # advertised, by id
    messages: list[tuple[str, int, bytes]] = field(default_factory=list)  # topic, log time, data
    error: BaseException | None = None

    def of(self, topic: str) -> list[bytes]:
        return [data for t, _, data in self.messages if t == topic]

    def json(self, topic: str) -> list[dict[str, Any]]:
        return [json.loads(d) for d in self.of(topic)]


class FoxgloveClient:
    """Connects (retrying until `connect_s`) in a thread of its own; `join()` waits for the
    server to close the connection and returns what was received."""

    def __init__(self, url: str, connect_s: float = 30.0) -> None:
        self.url = url
        self.connect_s = connect_s
        self.got = Received()
        self.subscribed = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def join(self, timeout_s: float) -> Received:
        self._thread.join(timeout_s)
        if self._thread.is_alive():
            raise AssertionError(f"{self.url}: the server did not close the connection")
        if self.got.error is not None:
            raise AssertionError(f"{self.url}: {self.got.error!r}")
        return self.got

    def _run(self) -> None:
        try:
            asyncio.run(self._main())
        except BaseException as exc:
            self.got.error = exc

    async def _main(self) -> None:
        deadline = time.monotonic() + self.connect_s
        while True:
            try:
                ws = await websockets.connect(self.url, subprotocols=SUBPROTOCOLS)  # type: ignore[arg-type]
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                await asyncio.sleep(0.05)
        self.got.subprotocol = ws.subprotocol
        subs: dict[int, int] = {}  # subscription id -> channel id
        try:
            async for frame in ws:
                if isinstance(frame, str):
                    msg = json.loads(frame)
                    if msg["op"] == "serverInfo":
                        self.got.server_info = msg
                    elif msg["op"] == "advertise":
                        new = []
                        for ch in msg["channels"]:
                            self.got.channels[ch["id"]] = ch
                            sub = len(subs)
                            subs[sub] = ch["id"]
                            new.append({"id": sub, "channelId": ch["id"]})
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))
                        self.subscribed.set()
                elif frame[0] == 0x01:
                    _, sub, log_time = _HEAD.unpack_from(frame)
                    topic = self.got.channels[subs[sub]]["topic"]
                    self.got.messages.append((topic, log_time, frame[_HEAD.size :]))
        except websockets.ConnectionClosed:
            pass
