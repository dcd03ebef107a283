"""The Foxglove WebSocket server of `sweep --live` and `replay --live` (foxglove-sdk).

It advertises the recording's own four channels, with the schemas the MCAP writer
registers (record/schemas.py: same topics, schema names, encodings and schema text, so a
layout made for a recording works live), and two channels a recording does not have:

- `/live/position`: each DAQ block's displacement beside the planned position (cycles.py)
- `/live/cycle`: each whole cycle as arrays, for F–x and F–v loops built cycle by cycle

Everything binds to 127.0.0.1 unless a host is named. A port that cannot be bound is a
ConfigError (one line) raised here, before any rig is touched.
"""

from __future__ import annotations

import json
import threading
import time
from typing import TYPE_CHECKING

from shockdyno.errors import ConfigError
from shockdyno.record import schemas as s

if TYPE_CHECKING:  # for the types only: foxglove is imported where it is used (below)
    # here: foxglove adds 13 ms to every command's start (measured)
    import foxglove
    from foxglove.websocket import ServerListener

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765  # Foxglove's own default for a WebSocket connection

TOPIC_POSITION = "/live/position"
TOPIC_CYCLE = "/live/cycle"

_NUMS = {"type": "array", "items": {"type": ["number", "null"]}}


def _schema(
    title: str, description: str, properties: dict[str, object], required: list[str]
) -> bytes:
    doc = {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        "required": required,
    }
    return json.dumps(doc, indent=1).encode()


POSITION_SCHEMA_NAME = "shockdyno.LivePosition"
POSITION_SCHEMA = _schema(
    POSITION_SCHEMA_NAME,
    "One DAQ block: the measured displacement beside the planned one.",
    {
        "test": {"type": ["integer", "null"], "description": "test serial (/dyno/test)"},
        "t_s": {**_NUMS, "description": "DAQ time, s"},
        "displacement_m": {**_NUMS, "description": "measured, m from the stroke centre"},
        "commanded_m": {**_NUMS, "description": "planned sine, m; null: no plan"},
        "error_m": {**_NUMS, "description": "measured - planned, m"},
        "force_n": _NUMS,
    },
    ["t_s", "displacement_m"],
)

CYCLE_SCHEMA_NAME = "shockdyno.LiveCycle"
CYCLE_SCHEMA = _schema(
    CYCLE_SCHEMA_NAME,
    "One whole cycle of a test, when it completes: F-x and F-v loops.",
    {
        "test": {"type": "integer", "description": "test serial (/dyno/test)"},
        "index": {"type": "integer", "description": "the sweep's test index"},
        "clicks": {"type": "integer"},
        "gas_clicks": {"type": "integer"},
        "frequency_hz": {"type": "number"},
        "amplitude_m": {"type": "number"},
        "cycle": {"type": "integer", "description": "cycle of the test, from 0"},
        "part": {"enum": ["ramp-in", "warm-up", "measured", "ramp-out"]},
        "t_start_s": {"type": "number"},
        "t_s": _NUMS,
        "displacement_m": _NUMS,
        "velocity_m_s": _NUMS,
        "force_n": _NUMS,
        "commanded_m": _NUMS,
        "peak_compression_force_n": {"type": ["number", "null"]},
        "peak_rebound_force_n": {"type": ["number", "null"]},
        "peak_velocity_m_s": {"type": ["number", "null"]},
    },
    ["test", "cycle", "part", "displacement_m", "force_n"],
)

# topic: (schema name, schema encoding, schema text, message encoding)
CHANNELS: dict[str, tuple[str, str, bytes, str]] = {
    s.TOPIC_SAMPLES: (s.SAMPLES_SCHEMA_NAME, "ros2msg", s.SAMPLES_SCHEMA.encode(), "cdr"),
    s.TOPIC_TEST: (s.TEST_SCHEMA_NAME, "jsonschema", s.TEST_SCHEMA, "json"),
    s.TOPIC_ACTUATOR: (s.ACTUATOR_SCHEMA_NAME, "jsonschema", s.ACTUATOR_SCHEMA, "json"),
    s.TOPIC_EVENTS: (s.EVENT_SCHEMA_NAME, "jsonschema", s.EVENT_SCHEMA, "json"),
    TOPIC_POSITION: (POSITION_SCHEMA_NAME, "jsonschema", POSITION_SCHEMA, "json"),
    TOPIC_CYCLE: (CYCLE_SCHEMA_NAME, "jsonschema", CYCLE_SCHEMA, "json"),
}


class LiveServer:
    """A running Foxglove WebSocket server with the channels above. `stop()` closes it."""

    def __init__(self, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT) -> None:
        import foxglove  # here: +6-13 ms CPU at every command's start-up (measured)

        if not 0 <= port <= 65535:
            raise ConfigError(f"--live-port must be 0-65535 (0: any free port), got {port}")
        self._context = foxglove.Context()
        listener, self._subscribed = _subscriptions()
        try:
            self._server = foxglove.start_server(
                name="shockdyno",
                host=host,
                port=port,
                context=self._context,
                server_listener=listener,
            )
        except RuntimeError as exc:
            raise ConfigError(_bind_error(host, port, str(exc))) from None
        self.host = host
        self.port = int(self._server.port)
        self._channels: dict[str, foxglove.Channel] = {}
        for topic, (name, encoding, data, message_encoding) in CHANNELS.items():
            schema = foxglove.Schema(name=name, encoding=encoding, data=data)
            self._channels[topic] = foxglove.Channel(
                topic, schema=schema, message_encoding=message_encoding, context=self._context
            )
        self._stopped = False

    @property
    def url(self) -> str:
        """The WebSocket URL a Foxglove viewer connects to (`ws://HOST:PORT`)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    def watched(self, topic: str) -> bool:
        """Someone is subscribed to the topic (nothing is encoded for no one)."""
        return bool(self._channels[topic].has_sinks())

    def wait_for_viewer(self, settle_s: float = 0.5) -> None:
        """Until a viewer subscribes (then `settle_s` more, for the rest of its panels'
        subscriptions). Only for a caller that drives no rig (`replay --live`)."""
        while not self._subscribed.wait(0.1):
            pass
        time.sleep(settle_s)

    def warn(self, text: str) -> None:
        """A warning every connected viewer shows (Foxglove's problems list); one id, so
        a newer one replaces the last."""
        import foxglove

        self._server.publish_status(text, foxglove.StatusLevel.Warning, id="shockdyno-live")

    def send(self, topic: str, log_time_ns: int, payload: bytes) -> None:
        """Send one encoded message on `topic`, stamped `log_time_ns` (ns since the epoch)."""
        self._channels[topic].log(payload, log_time=max(0, log_time_ns))

    def stop(self, flush_s: float = 0.5) -> None:
        """Close the server. A viewer gets `flush_s` first: the server sends from queues
        of its own, and stopping drops what they still hold (the test's end record)."""
        if self._stopped:
            return
        self._stopped = True
        if self._subscribed.is_set():
            time.sleep(flush_s)
        for channel in self._channels.values():
            channel.close()
        self._server.stop()


def _subscriptions() -> tuple[ServerListener, threading.Event]:
    """A ServerListener noting the first subscription (the SDK itself sends a channel
    only to its subscribers; every other callback is the protocol's own no-op), and the
    event it sets. foxglove is imported here, not by every command's start (see above)."""
    from foxglove.websocket import ChannelView, Client, ServerListener

    first = threading.Event()

    class Subscriptions(ServerListener):
        def on_subscribe(self, client: Client, channel: ChannelView) -> None:
            first.set()

    return Subscriptions(), first


def _bind_error(host: str, port: int, text: str) -> str:
    why = text.removeprefix("FoxgloveError: ").removeprefix("Failed to bind port: ")
    if "in use" in why:
        return (
            f"--live-port {port}: {host}:{port} is already in use (another `--live` "
            "or another program); choose another port with --live-port, or 0 for any free one"
        )
    if "lookup" in why or "not known" in why or "assign" in why:
        return f"--live-host {host}: cannot listen there ({why})"
    return f"the live view cannot listen on {host}:{port} ({why})"
