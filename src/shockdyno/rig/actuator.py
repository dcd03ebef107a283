"""Modbus actuator driver (pymodbus 3.16, TCP or RTU), driven by the rig file's register map.

Control paths use short timeouts and no retries: a request that fails raises `RigFault`
at once and the caller (RigSession) decides what to do. Calls are serialised by a lock.
Each request runs inside `guard()` (RigSession passes run/signals.hold): a signal that
arrives mid-request is raised when its answer is in, so the stop command that follows goes
out on a clean line (an RTU request torn by Ctrl-C would leave its answer to be read as
the stop's, which would then time out, delaying the stop).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Iterable, Mapping
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field

from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ModbusException
from pymodbus.pdu import ModbusPDU

from shockdyno.errors import RigFault
from shockdyno.rig.config import RigConfig
from shockdyno.rig.registers import decode_span, encode, span_of

# pymodbus logs every timeout with packet dumps on stderr; the driver reports each failure
# itself as one RigFault line, so its log is kept quiet, unless a level was chosen already
# (`shockdyno -v` shows the Modbus traffic when commissioning a drive).
if logging.getLogger("pymodbus").level == logging.NOTSET:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)

# Requests in register-map terms (name, value, words); with pymodbus's own frames this is what
# `shockdyno -v` shows when commissioning a drive.
log = logging.getLogger(__name__)

STATUS_NAMES = ("status_word", "fault_code", "position_actual", "force_actual", "cycle_count")


@dataclass(frozen=True)
class ActuatorStatus:
    """One read of the drive: the status word and its named bits, the fault code and its text,
    the ram's absolute position (m), the drive's own load (N) and cycle count where it has those
    registers, and any setpoints read back with it."""

    word: int
    bits: dict[str, bool]
    fault_code: int
    fault_text: str
    position_m: float
    force_n: float | None
    cycle_count: int | None
    setpoints: dict[str, float] = field(default_factory=dict)  # read back with the status

    @property
    def enabled(self) -> bool:
        return self.bits.get("enabled", False)

    @property
    def running(self) -> bool:
        return self.bits.get("running", False)

    @property
    def fault(self) -> bool:
        return self.bits.get("fault", False)

    @property
    def target_reached(self) -> bool:
        """Whether the drive says it reached its target (the hold-mode move's position)."""
        return self.bits.get("target_reached", False)

    def fields(self) -> dict[str, float | int | bool]:
        """The status as flat named values (word, fault code, position, each bit, and force and
        cycle count where read), as the recording's actuator channel stores them."""
        out: dict[str, float | int | bool] = {
            "status_word": self.word,
            "fault_code": self.fault_code,
            "position_m": self.position_m,
        }
        out.update(self.bits)
        if self.force_n is not None:
            out["force_n"] = self.force_n
        if self.cycle_count is not None:
            out["cycle_count"] = self.cycle_count
        return out


class ModbusActuator:
    """One drive on Modbus. `connect()` opens the transport; `close()` always releases it."""

    def __init__(
        self, rig: RigConfig, guard: Callable[[], AbstractContextManager[None]] = nullcontext
    ) -> None:
        self.rig = rig
        self._guard = guard
        self.map = rig.registers
        self._lock = threading.Lock()
        t = rig.actuator
        self._client: ModbusTcpClient | ModbusSerialClient
        if t.kind == "tcp":
            self._client = ModbusTcpClient(
                t.host, port=t.port, timeout=t.timeout_s, retries=0, reconnect_delay=0.0
            )
        else:
            self._client = ModbusSerialClient(
                t.serial_port,
                baudrate=t.baudrate,
                parity=t.parity,
                stopbits=t.stopbits,
                timeout=t.timeout_s,
                retries=0,
                reconnect_delay=0.0,
            )
        self._device = t.device_id
        self._heartbeat = 0
        self._enabled_bit = False
        self._status_names = [n for n in STATUS_NAMES if n in self.map]
        self._status_span = span_of(self.map, self._status_names)

    # -- transport ---------------------------------------------------------------------
    def connect(self) -> None:
        """Open the TCP or RTU transport; RigFault naming the endpoint when it cannot."""
        try:
            ok = self._client.connect()
        except (ModbusException, OSError) as exc:
            raise RigFault(f"{self.rig.actuator.describe()}: cannot connect ({exc})") from None
        if not ok:
            raise RigFault(f"{self.rig.actuator.describe()}: cannot connect")

    def close(self) -> None:
        """Release the transport (under the request lock: never mid-request)."""
        with self._lock:
            self._client.close()  # type: ignore[no-untyped-call]

    def _call(
        self, what: str, fn: Callable[..., ModbusPDU], *args: object, **kw: object
    ) -> ModbusPDU:
        with self._lock, self._guard():
            try:
                rr = fn(*args, device_id=self._device, **kw)
            except (ModbusException, OSError) as exc:
                msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                raise RigFault(f"{self.rig.actuator.describe()}: {what} failed ({msg})") from None
        if rr.isError():
            raise RigFault(f"{self.rig.actuator.describe()}: {what} refused ({rr})")
        log.debug("%s: %s", what, rr)
        return rr

    # -- registers ---------------------------------------------------------------------
    def read_words(self, address: int, count: int) -> list[int]:
        """`count` raw holding registers from `address` (FC3); RigFault on any failure or
        refusal."""
        rr = self._call(
            f"read {count} at {address}", self._client.read_holding_registers, address, count=count
        )
        return list(rr.registers)

    def read(self, names: Iterable[str]) -> dict[str, float]:
        """The named registers' engineering values (SI, or counts), in one read of the span they
        cover."""
        names = list(names)
        lo, count = span_of(self.map, names)
        values = decode_span(self.map, lo, self.read_words(lo, count), names)
        log.debug("read %s", values)
        return values

    def write(self, values: Mapping[str, float]) -> None:
        """Write each named register's engineering value (FC16, one request a register, in
        order)."""
        for name, value in values.items():
            reg = self.map[name]
            words = encode(reg, value, self.map.word_order)
            what = f"write {name} = {value:g} (words {words} at {reg.address})"
            self._call(what, self._client.write_registers, reg.address, words)

    # -- drive functions ---------------------------------------------------------------
    def control(self, *commands: str, enable: bool | None = None) -> None:
        """Write the control word: the enable level plus one-shot command bits."""
        if enable is not None:
            self._enabled_bit = enable
        bits = self.map.control_bits
        word = (1 << bits["enable"]) if self._enabled_bit else 0
        for c in commands:
            word |= 1 << bits[c]
        self.write({"control_word": word})

    def status(self, setpoints: Iterable[str] = ()) -> ActuatorStatus:
        """The drive's status, and the named setpoints as the drive holds them now (in the same
        read when the registers span at most 125 words, else in a second read)."""
        wanted = [n for n in setpoints if n in self.map]
        names = self._status_names + wanted
        lo, count = span_of(self.map, names)
        if count <= 125:
            values = decode_span(self.map, lo, self.read_words(lo, count), names)
        else:
            values = decode_span(
                self.map,
                self._status_span[0],
                self.read_words(*self._status_span),
                self._status_names,
            )
            values.update(self.read(wanted) if wanted else {})
        word = int(values["status_word"])
        bits = {k: bool(word >> b & 1) for k, b in self.map.status_bits.items()}
        code = int(values["fault_code"])
        return ActuatorStatus(
            word=word,
            bits=bits,
            fault_code=code,
            fault_text=self.map.fault_text(code) if code else "",
            position_m=float(values["position_actual"]),
            force_n=float(values["force_actual"]) if "force_actual" in values else None,
            cycle_count=int(values["cycle_count"]) if "cycle_count" in values else None,
            setpoints={n: float(values[n]) for n in wanted},
        )

    def beat(self) -> None:
        """Feed the drive's watchdog: write the next heartbeat count (wraps at 16 bits)."""
        self._heartbeat = (self._heartbeat + 1) & 0xFFFF
        self.write({"heartbeat": self._heartbeat})

    def set_mode(self, mode: str) -> None:
        """Write the drive's mode by name (`hold`, `sine`, ..., as the rig file's `modes` number
        them)."""
        self.write({"mode": self.map.modes[mode]})
