"""The simulated DAQ's serial byte stream to its listeners: TCP clients of a
`socket://` server and/or a pty, on 127.0.0.1. A slow reader loses new frames rather
than holding up the rig (SINK_LIMIT bytes queued at most)."""

from __future__ import annotations

import asyncio
import contextlib
import os
import tty
from dataclasses import dataclass, field

SINK_LIMIT = 1 << 20  # bytes queued for a slow reader before new frames are discarded


@dataclass
class _PtySink:
    master: int
    slave: int
    path: str
    pending: bytearray = field(default_factory=bytearray)

    def write(self, data: bytes) -> None:
        """Queue `data` (dropped when SINK_LIMIT bytes are waiting already) and write what the
        pty takes now."""
        if len(self.pending) < SINK_LIMIT:
            self.pending += data
        try:
            n = os.write(self.master, self.pending)
        except BlockingIOError:
            return
        except OSError:
            self.pending.clear()
            return
        del self.pending[:n]

    def close(self) -> None:
        """Close both ends of the pty."""
        for fd in (self.master, self.slave):
            with contextlib.suppress(OSError):
                os.close(fd)


class SerialStream:
    """The DAQ's frames, sent to every listener (`mode`: socket, pty or both)."""

    def __init__(self, mode: str) -> None:
        self.mode = mode
        self.port = 0
        self.pty_path = ""
        self._writers: list[asyncio.StreamWriter] = []
        self._pty: _PtySink | None = None
        self._server: asyncio.Server | None = None

    async def open(self, port: int) -> list[str]:
        """Listen (on `port`, 0: any free one) and open the pty, as `mode` says; the
        endpoints, in words."""
        endpoints = []
        if self.mode in ("socket", "both"):
            self._server = await asyncio.start_server(self._client, "127.0.0.1", port)
            self.port = int(self._server.sockets[0].getsockname()[1])
            endpoints.append(f"serial socket://127.0.0.1:{self.port}")
        if self.mode in ("pty", "both"):
            master, slave = os.openpty()
            tty.setraw(slave)
            os.set_blocking(master, False)
            self._pty = _PtySink(master, slave, os.ttyname(slave))
            self.pty_path = self._pty.path
            endpoints.append(f"serial {self.pty_path}")
        return endpoints

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._writers.append(writer)
        try:
            while await reader.read(4096):
                pass  # the DAQ ignores what the host sends
        except (ConnectionError, asyncio.CancelledError):
            pass
        finally:
            if writer in self._writers:
                self._writers.remove(writer)
            writer.close()

    def send(self, data: bytes) -> None:
        """Send the DAQ's bytes to every listener; a listener with SINK_LIMIT bytes waiting
        misses them."""
        for w in list(self._writers):
            if w.is_closing():
                self._writers.remove(w)
            elif w.transport.get_write_buffer_size() < SINK_LIMIT:
                w.write(data)
        if self._pty is not None:
            self._pty.write(data)

    def flush(self) -> None:
        """What a pty's reader was too slow for, tried again."""
        if self._pty is not None and self._pty.pending:
            self._pty.write(b"")

    def disconnect(self) -> None:
        """The DAQ's cable pulled: every listener's stream ends (the pty for good)."""
        for w in list(self._writers):
            w.close()
        self._writers.clear()
        if self._pty is not None:
            self._pty.close()
            self._pty = None

    async def close(self) -> None:
        """Stop listening and close every client and the pty."""
        if self._server is not None:
            self._server.close()
        for w in list(self._writers):
            w.close()
            with contextlib.suppress(Exception):
                await w.wait_closed()
        if self._server is not None:
            await self._server.wait_closed()
        if self._pty is not None:
            self._pty.close()
