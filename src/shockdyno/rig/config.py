"""Rig files (`rigs/*.toml`): transports, register map, DAQ calibration, limits, ramps.

Everything is validated on load through `shockdyno.schema` (the constraints are on the
fields' types below); every problem is one `ConfigError` line naming the file and the
key. The file text is kept (`raw_toml`) so recordings can carry it.
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Any, Literal

from msgspec import Meta

from shockdyno.schema import (
    Fraction,
    NonEmpty,
    Port,
    Positive,
    convert,
    dotted,
    fail,
    parse_toml,
    read_text,
    shown,
)

RegisterType = Literal["uint16", "int32", "float32"]
REGISTER_WIDTH: dict[str, int] = {"uint16": 1, "int32": 2, "float32": 2}

# Registers every actuator must provide (the driver and the simulated drive both rely on them).
REQUIRED_REGISTERS = (
    "control_word",
    "status_word",
    "mode",
    "fault_code",
    "heartbeat",
    "heartbeat_timeout_ms",
    "position_command",
    "position_actual",
    "move_velocity",
    "sine_amplitude",
    "sine_frequency",
    "sine_centre",
    "sine_cycles",
    "sine_ramp_cycles",
)
# The drive's own limits (travel_limit, velocity_limit, force_limit), where it has them, are
# read back before enabling: the rig file's trips must lie within them (run/session.py).
OPTIONAL_REGISTERS = (
    "rod_clicks",
    "gas_clicks",
    # A damper's own adjusters, motorised: these, or any NAME_clicks (ADJUSTER_REGISTER)
    "compression_clicks",
    "rebound_clicks",
    "force_actual",
    "cycle_count",
    "travel_limit",
    "velocity_limit",
    "force_limit",
    # Constant-velocity strokes (model/stroke.py): the drive's function generator's shape
    # (WAVEFORM_CODES), a trapezoid's reversal acceleration, and the most the drive can do.
    "waveform",
    "waveform_acceleration",
    "acceleration_limit",
)

# A damper's own adjuster, motorised: NAME_clicks for the spec's [adjuster.NAME]
ADJUSTER_REGISTER = re.compile(r"[a-z][a-z0-9_]{0,31}_clicks")

DEFAULT_CONTROL_BITS = {"enable": 0, "start": 1, "stop": 2, "quick_stop": 3, "fault_reset": 7}
DEFAULT_STATUS_BITS = {
    "ready": 0,
    "enabled": 1,
    "running": 2,
    "target_reached": 3,
    "fault": 4,
    "warning": 5,
}
DEFAULT_MODES = {"hold": 0, "sine": 1, "stream": 2}
WAVEFORM_CODES = {"sine": 0, "triangle": 1, "trapezoid": 2}  # the `waveform` register
Bit = Annotated[int, Meta(ge=0, le=15)]
Word = Annotated[int, Meta(ge=0, le=65535)]
# The text a register map gives its drive's watchdog fault: its fault reaction ends in a
# disable, which a session's stop waits for before it resets and centres (run/session.py).
WATCHDOG_FAULT = "heartbeat lost"
DEFAULT_FAULT_CODES = {
    1: WATCHDOG_FAULT,
    2: "over-force",
    3: "over-velocity",
    4: "travel limit",
    5: "drive fault",
    6: "start refused: not at sine centre",
    7: "start refused: bad sine parameters",
}


@dataclass(frozen=True)
class Register:
    """One register of the drive: its address, type (uint16, int32, float32), the scale from raw
    to engineering value (value = raw × scale; SI or a count), and whether the host writes it."""

    name: str
    address: Port
    type: RegisterType
    scale: Positive = 1.0  # engineering value = raw * scale
    writable: bool = True

    @property
    def width(self) -> int:
        """The register's width in 16-bit words (1 or 2)."""
        return REGISTER_WIDTH[self.type]


@dataclass(frozen=True)
class RegisterMap:
    """The drive's register map as the rig file declares it: the registers by name, the word
    order of 32-bit values, the control and status bit numbers, the mode numbers and the fault
    codes' texts."""

    registers: dict[str, Register]
    word_order: Literal["big", "little"] = "big"  # which 16-bit word of a 32-bit value comes first
    control_bits: dict[str, Bit] = field(default_factory=lambda: dict(DEFAULT_CONTROL_BITS))
    status_bits: dict[str, Bit] = field(default_factory=lambda: dict(DEFAULT_STATUS_BITS))
    modes: dict[str, Word] = field(default_factory=lambda: dict(DEFAULT_MODES))
    fault_codes: dict[int, NonEmpty] = field(default_factory=lambda: dict(DEFAULT_FAULT_CODES))

    def __getitem__(self, name: str) -> Register:
        return self.registers[name]

    def __contains__(self, name: object) -> bool:
        return name in self.registers

    @property
    def span(self) -> tuple[int, int]:
        """First address and number of registers covering the whole map."""
        lo = min(r.address for r in self.registers.values())
        hi = max(r.address + r.width for r in self.registers.values())
        return lo, hi - lo

    def fault_text(self, code: int) -> str:
        """The text of a drive fault code (`fault code N` for one the rig file does not name)."""
        return self.fault_codes.get(code, f"fault code {code}")


@dataclass(frozen=True)
class ModbusTransport:
    """How the drive is reached: Modbus TCP (host, port) or RTU (serial port, baud rate, parity,
    stop bits), its device id and the timeout of every request (s)."""

    kind: Literal["tcp", "rtu"]  # the file's `transport`
    host: NonEmpty = "127.0.0.1"
    port: Port = 502
    serial_port: str = ""
    baudrate: Annotated[int, Meta(ge=300, le=4_000_000)] = 19200
    parity: Literal["N", "E", "O"] = "N"
    stopbits: Annotated[int, Meta(ge=1, le=2)] = 1
    device_id: Annotated[int, Meta(ge=0, le=247)] = 1
    timeout_s: Positive = 0.3

    def describe(self) -> str:
        """The endpoint for messages: `modbus tcp://HOST:PORT` or `modbus rtu PORT @BAUD`."""
        if self.kind == "tcp":
            return f"modbus tcp://{self.host}:{self.port}"
        return f"modbus rtu {self.serial_port} @{self.baudrate}"


@dataclass(frozen=True)
class Calibration:
    """Counts to SI: value = counts * gain + offset."""

    force_n_per_count: Positive
    position_m_per_count: Positive
    temperature_c_per_count: Positive
    force_offset_n: float = 0.0
    position_offset_m: float = 0.0  # LVDT reading (absolute ram position) at zero counts
    temperature_offset_c: float = 0.0


@dataclass(frozen=True, kw_only=True)
class DaqConfig:
    """The serial DAQ ([daq]): its pyserial URL, sample rate (Hz), calibration from counts to SI,
    link speed, the trips on a frozen stream or a gap, the frame loss a test may have, and each
    sensor's plausible range (readings outside are refused)."""

    url: NonEmpty
    sample_rate_hz: Positive
    calibration: Calibration
    baudrate: Annotated[int, Meta(ge=300, le=20_000_000)] = 921600
    # DAQ seconds per wall-clock second: 1 for hardware; a simulated rig run at --speed N
    # says N. The frame rate measured before enabling (run/session.py) and by `rig check`
    # is checked against `frames_per_host_s`.
    time_scale: Annotated[float, Meta(gt=0, le=1000)] = 1.0
    frozen_timeout_s: Positive = 0.5  # wall time without a valid frame: the DAQ is frozen
    max_gap_s: Positive = 0.05  # a longer run of lost frames leaves the limits unwatched: stop
    max_frame_loss: Fraction = 0.01  # a test losing a larger fraction of its frames is degraded
    # The sensors' ranges (LVDT absolute, load cell, thermometer): a reading outside cannot
    # be real. Defaults from the limits: stroke centre ± 4 travel, ± 4 force limit.
    position_range_m: tuple[float, float] = (-math.inf, math.inf)
    force_range_n: tuple[float, float] = (-math.inf, math.inf)
    temperature_range_c: tuple[float, float] = (-40.0, 200.0)

    @property
    def frames_per_host_s(self) -> float:
        """The frame rate to expect on the host: sample_rate_hz × time_scale (a simulated
        rig at N × real time sends N × the frames per host second)."""
        return self.sample_rate_hz * self.time_scale

    @property
    def time_scale_note(self) -> str:
        """' x daq.time_scale 5' after a frame rate the time scale multiplied; empty at
        real time."""
        return "" if self.time_scale == 1.0 else f" x daq.time_scale {self.time_scale:g}"


# What a shock-absorber dyno can be at all. A limit beyond is a typo or another unit (mm
# for m), and a session would check every sample against a limit the ram can never reach.
PLAUSIBLE_LIMITS = {
    "travel_m": (0.5, "m (a damper's stroke is well below a metre)"),
    "force_n": (200_000.0, "N (200 kN: beyond any damper dyno's load cell)"),
    "velocity_m_s": (15.0, "m/s (beyond any damper dyno's actuator)"),
    "temperature_c": (200.0, "°C (beyond any damper oil's)"),
}
MAX_WATCHDOG_S = 5.0  # a longer drive watchdog leaves a dead host's ram moving too long


@dataclass(frozen=True)
class Limits:
    """The rig file's test limits: travel (m from stroke centre), force (N), velocity (m/s) and
    temperature (°C); the run-time trips sit `trip_margin` beyond them."""

    travel_m: Positive  # largest |displacement| from stroke centre
    force_n: Positive
    velocity_m_s: Positive
    temperature_c: Positive
    trip_margin: Fraction = 0.05  # runtime trips sit this fraction beyond the test limits


@dataclass(frozen=True)
class RampConfig:
    """How the ram moves gently: sine amplitude ramped in and out over whole cycles, hold-mode
    moves at `move_velocity_m_s` (m/s), a controlled stop over `stop_time_s` (s)."""

    sine_ramp_cycles: Annotated[int, Meta(ge=1, le=100)] = 1  # amplitude ramps over these cycles
    move_velocity_m_s: Positive = 0.01  # speed of moves in hold mode (to centre, parking)
    stop_time_s: Positive = 0.5  # controlled stop: amplitude ramps to zero over this time


@dataclass(frozen=True)
class VerifyConfig:
    """How closely a finished test's measured motion must match its plan to be complete."""

    frequency_tolerance: Positive = 0.01  # relative
    amplitude_tolerance: Positive = 0.05  # relative
    centre_tolerance_m: Positive = 0.001


@dataclass(frozen=True)
class HeartbeatConfig:
    """The drive's watchdog: the host writes a heartbeat every `period_s` (s); the drive stops
    and disables itself when none comes within `timeout_s` (s)."""

    period_s: Positive = 0.1
    timeout_s: Positive = 0.5


@dataclass(frozen=True)
class RigConfig:
    """One rig file, checked: the drive's transport and register map, the DAQ, the limits, the
    stroke centre (m, absolute ram position), how the adjuster is set (motorised or an operator),
    ramps, heartbeat, the drive's poll period (s) and how closely a test must match its plan."""

    name: str
    source: str  # file the config came from (for messages)
    actuator: ModbusTransport
    registers: RegisterMap
    daq: DaqConfig
    limits: Limits
    stroke_centre_m: float
    adjuster: Literal["motorised", "operator"]
    ramp: RampConfig
    heartbeat: HeartbeatConfig
    poll_period_s: float = 0.02
    verify: VerifyConfig = field(default_factory=VerifyConfig)
    # [simulation] as tomllib read it (Any: a TOML value): sim-rig only, SimParams checks it
    simulation: dict[str, Any] = field(default_factory=dict)
    raw_toml: str = ""

    @property
    def sample_rate_hz(self) -> float:
        """The DAQ's sample rate (Hz): a recording's time base."""
        return self.daq.sample_rate_hz

    def with_endpoints(
        self, *, host: str | None = None, port: int | None = None, daq_url: str | None = None
    ) -> RigConfig:
        """A copy with the drive reached at another TCP host or port (which makes it TCP) and/or
        the DAQ at another URL."""
        act = self.actuator
        if host is not None or port is not None:
            act = replace(
                act,
                kind="tcp",
                host=host if host is not None else act.host,
                port=port if port is not None else act.port,
            )
        daq = self.daq if daq_url is None else replace(self.daq, url=daq_url)
        return replace(self, actuator=act, daq=daq)


# -- loading ---------------------------------------------------------------------------

SPECIAL_TABLES = ("word_order", "control_bits", "status_bits", "modes", "fault_codes")
TRANSPORT_KEYS = {
    "tcp": ("host", "port"),
    "rtu": ("serial_port", "baudrate", "parity", "stopbits"),
}


@dataclass(frozen=True)
class _RigTable:
    """The file's [rig] table."""

    name: NonEmpty
    stroke_centre_m: float
    adjuster: Literal["motorised", "operator"] = "operator"
    poll_period_s: Positive = 0.02


@dataclass(frozen=True)
class _RigFile:
    """The file's shape. [actuator] and [daq] are checked on their own (the transport
    decides the actuator's keys; the DAQ's ranges default from the limits), so they stay
    tables as tomllib gives them (dict[str, Any]: any TOML value) until then."""

    rig: _RigTable
    actuator: dict[str, Any]
    daq: dict[str, Any]
    limits: Limits
    ramp: RampConfig = field(default_factory=RampConfig)
    heartbeat: HeartbeatConfig = field(default_factory=HeartbeatConfig)
    verify: VerifyConfig = field(default_factory=VerifyConfig)
    simulation: dict[str, Any] = field(default_factory=dict)  # SimParams.from_rig reads it


def _transport(act: dict[str, Any], src: str) -> ModbusTransport:  # Any: TOML values
    keys = {k: v for k, v in act.items() if k != "registers"}
    if "kind" in keys:
        raise fail(src, "actuator.kind", "unknown key (did you mean transport?)")
    kind = keys.pop("transport", None)
    if kind is None:
        raise fail(src, "actuator.transport", "missing")
    if not isinstance(kind, str) or kind not in TRANSPORT_KEYS:
        raise fail(src, "actuator.transport", f"must be one of tcp, rtu; got {shown(kind)}")
    for other, names in TRANSPORT_KEYS.items():
        for name in names:
            if other != kind and name in keys:
                raise fail(src, f"actuator.{name}", f"not used with transport = {kind!r}")
    need = TRANSPORT_KEYS[kind][0]
    if need not in keys:
        raise fail(src, f"actuator.{need}", "missing")
    return convert({**keys, "kind": kind}, ModbusTransport, src, "actuator")


def _register_map(tables: Any, src: str) -> RegisterMap:  # Any: a TOML value, checked here
    at = "actuator.registers"
    if not isinstance(tables, dict):
        raise fail(src, at, "missing table" if tables is None else "must be a table")
    regs: dict[str, Register] = {}
    known = (*REQUIRED_REGISTERS, *OPTIONAL_REGISTERS)
    for name, entry in tables.items():
        if name in SPECIAL_TABLES:
            continue
        if name not in known and not ADJUSTER_REGISTER.fullmatch(name):
            # a misspelt optional register would silently be absent (a misspelt NAME_clicks
            # is named when a sweep over that adjuster finds its register missing)
            near = difflib.get_close_matches(name, known, n=1)
            hint = f"did you mean {near[0]}?" if near else f"known: {', '.join(known)}"
            raise fail(src, dotted(at, name), f"unknown register ({hint})")
        if not isinstance(entry, dict):
            raise fail(src, f"{at}.{name}", 'must be a table { address = N, type = "..." }')
        if "name" in entry:
            raise fail(src, f"{at}.{name}.name", "unknown key")
        regs[name] = convert({**entry, "name": name}, Register, src, f"{at}.{name}")
    for name in REQUIRED_REGISTERS:
        if name not in regs:
            raise fail(src, f"{at}.{name}", "missing register")
    taken: dict[int, str] = {}
    for reg in sorted(regs.values(), key=lambda g: g.address):
        for a in range(reg.address, reg.address + reg.width):
            if a in taken:
                raise fail(src, f"{at}.{reg.name}", f"address {a} overlaps register {taken[a]}")
            taken[a] = reg.name
    span = max(taken) - min(taken) + 1
    if span > 125:
        raise fail(src, at, f"register map spans {span} registers; one read covers at most 125")
    given = {k: tables[k] for k in SPECIAL_TABLES if k in tables}
    codes = given.get("fault_codes", {})
    if isinstance(codes, dict):
        numbered: dict[int, Any] = {}  # Any: the TOML values, checked below
        for key, text in codes.items():
            where = dotted(f"{at}.fault_codes", key)
            if not re.fullmatch(r"[0-9]{1,5}", key) or int(key) > 65535:
                raise fail(src, where, "fault codes are whole numbers 0-65535 (a uint16)")
            if int(key) in numbered:
                raise fail(src, where, f"fault code {int(key)} given twice")
            numbered[int(key)] = text
        given["fault_codes"] = numbered
    rm = convert({**given, "registers": {}}, RegisterMap, src, at)
    merged: dict[str, dict[str, int]] = {}
    for table, defaults in (
        ("control_bits", DEFAULT_CONTROL_BITS),
        ("status_bits", DEFAULT_STATUS_BITS),
        ("modes", DEFAULT_MODES),
    ):
        merged[table] = both = {**defaults, **getattr(rm, table)}
        for name, value in getattr(rm, table).items():
            if name not in defaults:
                near = difflib.get_close_matches(name, defaults, n=1)
                hint = f"did you mean {near[0]}?" if near else f"known: {', '.join(defaults)}"
                raise fail(src, dotted(f"{at}.{table}", name), f"unknown name ({hint})")
            twin = next((k for k, v in both.items() if v == value and k != name), None)
            if twin is not None:
                raise fail(src, dotted(f"{at}.{table}", name), f"{value} is {twin}'s too")
    return replace(
        rm,
        registers=regs,
        control_bits=merged["control_bits"],
        status_bits=merged["status_bits"],
        modes=merged["modes"],
        fault_codes={**DEFAULT_FAULT_CODES, **rm.fault_codes},
    )


def _daq(doc: dict[str, Any], limits: Limits, centre: float, src: str) -> DaqConfig:  # TOML
    daq = convert(doc, DaqConfig, src, "daq")
    bits_per_s = daq.sample_rate_hz * 18 * 10  # 18-byte frames, 10 bits per byte on the wire
    if not daq.url.startswith(("socket://", "loop://")) and bits_per_s > daq.baudrate:
        raise fail(
            src,
            "daq.baudrate",
            f"{daq.baudrate} baud cannot carry {daq.sample_rate_hz:g} frames/s "
            f"(needs {bits_per_s:.0f})",
        )
    defaults = {  # what a sensor can read at all, from the limits
        "position_range_m": (centre - 4 * limits.travel_m, centre + 4 * limits.travel_m),
        "force_range_n": (-4 * limits.force_n, 4 * limits.force_n),
    }
    ranges = {k: v for k, v in defaults.items() if k not in doc}
    for key in ("position_range_m", "force_range_n", "temperature_range_c"):
        lo, hi = ranges.get(key, getattr(daq, key))
        if not lo < hi:
            raise fail(src, f"daq.{key}", f"must be [LOW, HIGH] with LOW < HIGH, got {doc[key]}")
    # A trip the sensor cannot read never trips: each limit (with its margin) must lie
    # inside the range of the sensor that watches it.
    m = 1 + limits.trip_margin
    travel = limits.travel_m * m
    watched = (
        ("position_range_m", "travel_m", centre - travel, centre + travel),
        ("force_range_n", "force_n", -limits.force_n * m, limits.force_n * m),
        ("temperature_range_c", "temperature_c", limits.temperature_c, limits.temperature_c),
    )
    for key, limit, lo_needed, hi_needed in watched:
        if key not in doc:
            continue
        lo, hi = getattr(daq, key)
        if lo_needed < lo or hi_needed > hi:
            raise fail(
                src,
                f"limits.{limit}",
                f"trips at [{lo_needed:g}, {hi_needed:g}] (with trip_margin), outside the "
                f"sensor's daq.{key} [{lo:g}, {hi:g}]: the sensor could never show the trip",
            )
    return replace(
        daq,
        position_range_m=ranges.get("position_range_m", daq.position_range_m),
        force_range_n=ranges.get("force_range_n", daq.force_range_n),
    )


def parse_rig(text: str, source: str = "<rig>") -> RigConfig:
    """Build a validated RigConfig from TOML text."""
    f = convert(parse_toml(text, source), _RigFile, source)
    regs = _register_map(f.actuator.get("registers"), source)
    transport = _transport(f.actuator, source)
    if f.rig.adjuster == "motorised" and not ("rod_clicks" in regs and "gas_clicks" in regs):
        raise fail(source, "rig.adjuster", "motorised needs registers rod_clicks and gas_clicks")
    hb = f.heartbeat
    if hb.timeout_s < 2 * hb.period_s:
        raise fail(source, "heartbeat.timeout_s", "must be at least twice period_s")
    if hb.timeout_s > MAX_WATCHDOG_S:
        raise fail(
            source,
            "heartbeat.timeout_s",
            f"must be at most {MAX_WATCHDOG_S:g} s (the time a ram moves on after the host "
            f"is gone), got {hb.timeout_s:g}",
        )
    for key, (most, what) in PLAUSIBLE_LIMITS.items():
        value = getattr(f.limits, key)
        if value > most:
            raise fail(source, f"limits.{key}", f"must be at most {most:g} {what}, got {value:g}")
    if f.ramp.move_velocity_m_s > f.limits.velocity_m_s:
        raise fail(
            source,
            "ramp.move_velocity_m_s",
            f"{f.ramp.move_velocity_m_s:g} m/s exceeds limits.velocity_m_s "
            f"({f.limits.velocity_m_s:g} m/s)",
        )
    return RigConfig(
        name=f.rig.name,
        source=source,
        actuator=transport,
        registers=regs,
        daq=_daq(f.daq, f.limits, f.rig.stroke_centre_m, source),
        limits=f.limits,
        stroke_centre_m=f.rig.stroke_centre_m,
        adjuster=f.rig.adjuster,
        ramp=f.ramp,
        heartbeat=hb,
        poll_period_s=f.rig.poll_period_s,
        verify=f.verify,
        simulation=dict(f.simulation),
        raw_toml=text,
    )


def default_rig_path() -> Path:
    """rigs/sim.toml of this checkout, else of the current directory."""
    here = Path(__file__).resolve().parents[3] / "rigs" / "sim.toml"
    return here if here.exists() else Path("rigs/sim.toml")


def load_rig(path: str | Path) -> RigConfig:
    """Read and validate a rig file; every problem is a one-line ConfigError."""
    p = Path(path)
    return parse_rig(read_text(p, f"rig file not found: {p}"), str(p))
