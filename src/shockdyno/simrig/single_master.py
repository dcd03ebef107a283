"""A Modbus TCP server that takes writes from one master only.

A drive that any client on the network may write to can have its test changed under the
host's feet (another master rewriting the sine frequency, the clicks or the watchdog).
What to recommend for real drives, and what the simulated rig can do on request: the
first connection that writes holds the drive; writes from any other connection are
answered with the Modbus exception "server device busy" (0x06) and change nothing, reads
stay open to everyone (a monitor may watch). The holder releases it by disconnecting.
"""

from __future__ import annotations

from typing import Any

from pymodbus.constants import ExcCodes
from pymodbus.pdu import ExceptionResponse
from pymodbus.server import ModbusTcpServer
from pymodbus.server.requesthandler import ServerRequestHandler

# Write coils/registers (single, multiple), mask write, read-write multiple.
WRITE_FUNCTION_CODES = frozenset({0x05, 0x06, 0x0F, 0x10, 0x16, 0x17})


class _OneMasterHandler(ServerRequestHandler):
    server: SingleMasterTcpServer

    async def handle_request(self) -> None:
        """Answer a write from any connection but the holder's with "server device busy"; the
        first connection that writes becomes the holder."""
        pdu = self.last_pdu
        if pdu is not None and pdu.function_code in WRITE_FUNCTION_CODES:
            holder = self.server.master
            if holder is None:
                self.server.master = self
            elif holder is not self:
                self.server.refused += 1
                refusal = ExceptionResponse(pdu.function_code, ExcCodes.DEVICE_BUSY)
                refusal.transaction_id = pdu.transaction_id
                refusal.dev_id = pdu.dev_id
                self.server_send(refusal, self.last_addr)  # type: ignore[no-untyped-call]
                return
        await super().handle_request()  # type: ignore[no-untyped-call]

    def callback_disconnected(self, exc: Exception | None) -> None:
        """Release the drive when its holder disconnects."""
        if self.server.master is self:
            self.server.master = None
        super().callback_disconnected(exc)


class SingleMasterTcpServer(ModbusTcpServer):
    """A Modbus TCP server whose first writing connection holds the drive: other connections'
    writes are refused (counted in `refused`), reads are open to all."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:  # Any: ModbusTcpServer's own
        super().__init__(*args, **kwargs)
        self.master: _OneMasterHandler | None = None
        self.refused = 0  # writes answered "busy"

    def callback_new_connection(self) -> _OneMasterHandler:
        """Each connection's handler, the one that enforces the single master."""
        handler = _OneMasterHandler(self, self.trace_packet, self.trace_pdu, self.trace_connect)  # type: ignore[no-untyped-call]
        return handler
