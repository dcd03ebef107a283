"""Rig files (`rigs/*.toml`): transports, register map, DAQ calibration, limits, ramps.

Everything is validated on load; every problem is one `ConfigError` line naming the file
and the key. The file text is kept (`raw_toml`) so recordings can carry it.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

from shockdyno.errors import ConfigError

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
OPTIONAL_REGISTERS = ("rod_clicks", "gas_clicks", "force_actual", "cycle_count")

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
DEFAULT_FAULT_CODES = {
    1: "heartbeat lost",
    2: "over-force",
    3: "over-velocity",
    4: "travel limit",
    5: "drive fault",
    6: "start refused: not at sine centre",
    7: "start refused: bad sine parameters",
}


@dataclass(frozen=True)
class Register:
    name: str
    address: int
    type: RegisterType
    scale: float = 1.0  # engineering value = raw * scale
    writable: bool = True

    @property
    def width(self) -> int:
        return REGISTER_WIDTH[self.type]


@dataclass(frozen=True)
class RegisterMap:
    registers: dict[str, Register]
    word_order: Literal["big", "little"] = "big"  # which 16-bit word of a 32-bit value comes first
    control_bits: dict[str, int] = field(default_factory=lambda: dict(DEFAULT_CONTROL_BITS))
    status_bits: dict[str, int] = field(default_factory=lambda: dict(DEFAULT_STATUS_BITS))
    modes: dict[str, int] = field(default_factory=lambda: dict(DEFAULT_MODES))
    fault_codes: dict[int, str] = field(default_factory=lambda: dict(DEFAULT_FAULT_CODES))

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
        return self.fault_codes.get(code, f"fault code {code}")


@dataclass(frozen=True)
class ModbusTransport:
    kind: Literal["tcp", "rtu"]
    host: str = "127.0.0.1"
    port: int = 502
    serial_port: str = ""
    baudrate: int = 19200
    parity: str = "N"
    stopbits: int = 1
    device_id: int = 1
    timeout_s: float = 0.3

    def describe(self) -> str:
        if self.kind == "tcp":
            return f"modbus tcp://{self.host}:{self.port}"
        return f"modbus rtu {self.serial_port} @{self.baudrate}"


@dataclass(frozen=True)
class Calibration:
    """Counts to SI: value = counts * gain + offset."""

    force_n_per_count: float
    force_offset_n: float
    position_m_per_count: float
    position_offset_m: float  # LVDT reading (absolute ram position) at zero counts
    temperature_c_per_count: float
    temperature_offset_c: float


@dataclass(frozen=True)
class DaqConfig:
    url: str
    baudrate: int
    sample_rate_hz: float
    calibration: Calibration
    frozen_timeout_s: float = 0.5  # wall time without a valid frame before the DAQ counts as frozen
    max_gap_s: float = 0.05  # a longer run of lost frames leaves the limits unwatched: stop
    max_frame_loss: float = 0.01  # a test losing a larger fraction of its frames is degraded
    # The sensors' ranges (LVDT absolute, load cell, thermometer): a reading outside cannot
    # be real. Defaults from the limits: stroke centre ± 4 travel, ± 4 force limit.
    position_range_m: tuple[float, float] = (-math.inf, math.inf)
    force_range_n: tuple[float, float] = (-math.inf, math.inf)
    temperature_range_c: tuple[float, float] = (-40.0, 200.0)


@dataclass(frozen=True)
class Limits:
    travel_m: float  # largest |displacement| from stroke centre
    force_n: float
    velocity_m_s: float
    temperature_c: float
    trip_margin: float = (
        0.05  # runtime trips sit this fraction beyond the limits tests must respect
    )


@dataclass(frozen=True)
class RampConfig:
    sine_ramp_cycles: int = 1  # amplitude ramps in and out over this many cycles
    move_velocity_m_s: float = 0.01  # speed of moves in hold mode (to centre, parking)
    stop_time_s: float = 0.5  # controlled stop: amplitude ramps to zero over this time


@dataclass(frozen=True)
class VerifyConfig:
    """How closely a finished test's measured motion must match its plan to be complete."""

    frequency_tolerance: float = 0.01  # relative
    amplitude_tolerance: float = 0.05  # relative
    centre_tolerance_m: float = 0.001


@dataclass(frozen=True)
class HeartbeatConfig:
    period_s: float = 0.1
    timeout_s: float = 0.5


@dataclass(frozen=True)
class RigConfig:
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
    simulation: dict[str, Any] = field(default_factory=dict)  # [simulation]: sim-rig only
    raw_toml: str = ""

    @property
    def sample_rate_hz(self) -> float:
        return self.daq.sample_rate_hz

    def with_endpoints(
        self, *, host: str | None = None, port: int | None = None, daq_url: str | None = None
    ) -> RigConfig:
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


class _Reader:
    """Typed access to one TOML table; errors name the file and the dotted key."""

    def __init__(self, src: str, data: dict[str, Any], prefix: str = "") -> None:
        self.src, self.data, self.prefix = src, data, prefix
        self.used: set[str] = set()

    def _key(self, key: str) -> str:
        return f"{self.prefix}{key}"

    def fail(self, key: str, what: str) -> ConfigError:
        return ConfigError(f"{self.src}: {self._key(key)}: {what}")

    def table(self, key: str, required: bool = True) -> _Reader:
        self.used.add(key)
        value = self.data.get(key)
        if value is None and not required:
            return _Reader(self.src, {}, f"{self._key(key)}.")
        if not isinstance(value, dict):
            raise self.fail(key, "missing table" if value is None else "must be a table")
        return _Reader(self.src, value, f"{self._key(key)}.")

    def raw(self, key: str, default: Any = ...) -> Any:
        self.used.add(key)
        if key not in self.data:
            if default is ...:
                raise self.fail(key, "missing")
            return default
        return self.data[key]

    def num(self, key: str, default: Any = ..., *, positive: bool = True) -> float:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"must be a number, got {value!r}")
        v = float(value)
        if not math.isfinite(v) or (positive and v <= 0):
            raise self.fail(key, f"must be {'> 0' if positive else 'finite'}, got {value!r}")
        return v

    def int_(self, key: str, default: Any = ..., *, lo: int = 0, hi: int = 2**31) -> int:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, f"must be an integer, got {value!r}")
        if not lo <= value <= hi:
            raise self.fail(key, f"must be {lo}-{hi}, got {value}")
        return value

    def bool_(self, key: str, default: Any = ...) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):  # bool("false") is True: a string is refused
            raise self.fail(key, f"must be true or false (no quotes), got {value!r}")
        return value

    def str_(self, key: str, default: Any = ..., choices: tuple[str, ...] = ()) -> str:
        value = self.raw(key, default)
        if not isinstance(value, str) or not value:
            raise self.fail(key, f"must be a non-empty string, got {value!r}")
        if choices and value not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}; got {value!r}")
        return value

    def check_unknown(self) -> None:
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            raise self.fail(unknown[0], "unknown key")


def _bits(r: _Reader, key: str, default: dict[str, int], hi: int) -> dict[str, int]:
    t = r.table(key, required=False)
    out = dict(default)
    for name in t.data:
        out[name] = t.int_(name, lo=0, hi=hi)
    return out


def _register_map(r: _Reader) -> RegisterMap:
    word_order = r.str_("word_order", "big", ("big", "little"))
    regs: dict[str, Register] = {}
    for name, value in r.data.items():
        if not isinstance(value, dict) or name in (
            "control_bits",
            "status_bits",
            "modes",
            "fault_codes",
        ):
            continue
        t = r.table(name)
        reg = Register(
            name=name,
            address=t.int_("address", lo=0, hi=65535),
            type=t.str_("type", choices=tuple(REGISTER_WIDTH)),  # type: ignore[arg-type]
            scale=t.num("scale", 1.0),
            writable=t.bool_("writable", True),
        )
        t.check_unknown()
        regs[name] = reg
    for name in REQUIRED_REGISTERS:
        if name not in regs:
            raise r.fail(name, "missing register")
    taken: dict[int, str] = {}
    for reg in sorted(regs.values(), key=lambda g: g.address):
        for a in range(reg.address, reg.address + reg.width):
            if a in taken:
                raise r.fail(reg.name, f"address {a} overlaps register {taken[a]}")
            taken[a] = reg.name
    span = max(a for a in taken) - min(taken) + 1
    if span > 125:
        raise r.fail("", f"register map spans {span} registers; one read covers at most 125")
    codes_t = r.table("fault_codes", required=False)
    codes = dict(DEFAULT_FAULT_CODES)
    for key in codes_t.data:
        try:
            codes[int(key)] = codes_t.str_(key)
        except ValueError:
            raise codes_t.fail(key, "fault codes are integers") from None
    rm = RegisterMap(
        registers=regs,
        word_order=word_order,  # type: ignore[arg-type]
        control_bits=_bits(r, "control_bits", DEFAULT_CONTROL_BITS, 15),
        status_bits=_bits(r, "status_bits", DEFAULT_STATUS_BITS, 15),
        modes=_bits(r, "modes", DEFAULT_MODES, 65535),
        fault_codes=codes,
    )
    r.check_unknown()
    return rm


def _transport(r: _Reader) -> ModbusTransport:
    kind = r.str_("transport", choices=("tcp", "rtu"))
    common = {
        "device_id": r.int_("device_id", 1, lo=0, hi=247),
        "timeout_s": r.num("timeout_s", 0.3),
    }
    if kind == "tcp":
        t = ModbusTransport(
            kind="tcp",
            host=r.str_("host"),
            port=r.int_("port", 502, lo=0, hi=65535),
            **common,  # type: ignore[arg-type]
        )
    else:
        t = ModbusTransport(
            kind="rtu",
            serial_port=r.str_("serial_port"),
            baudrate=r.int_("baudrate", 19200, lo=300, hi=4_000_000),
            parity=r.str_("parity", "N", ("N", "E", "O")),
            stopbits=r.int_("stopbits", 1, lo=1, hi=2),
            **common,  # type: ignore[arg-type]
        )
    return t


def _range(t: _Reader, key: str, default: tuple[float, float]) -> tuple[float, float]:
    value = t.raw(key, list(default))
    ok = isinstance(value, list) and len(value) == 2
    ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    if not ok or not (math.isfinite(value[0]) and math.isfinite(value[1]) and value[0] < value[1]):
        raise t.fail(key, f"must be [LOW, HIGH] with LOW < HIGH, got {value!r}")
    return float(value[0]), float(value[1])


def parse_rig(text: str, source: str = "<rig>") -> RigConfig:
    """Build a validated RigConfig from TOML text."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML ({exc})") from None
    top = _Reader(source, doc)
    rig = top.table("rig")
    name = rig.str_("name")
    centre = rig.num("stroke_centre_m", positive=False)
    adjuster = rig.str_("adjuster", "operator", ("motorised", "operator"))
    poll = rig.num("poll_period_s", 0.02)
    rig.check_unknown()

    act_t = top.table("actuator")
    transport = _transport(act_t)
    regs = _register_map(act_t.table("registers"))
    act_t.check_unknown()
    if adjuster == "motorised" and not ("rod_clicks" in regs and "gas_clicks" in regs):
        raise rig.fail("adjuster", "motorised needs registers rod_clicks and gas_clicks")

    daq_t = top.table("daq")
    cal_t = daq_t.table("calibration")
    cal = Calibration(
        force_n_per_count=cal_t.num("force_n_per_count"),
        force_offset_n=cal_t.num("force_offset_n", 0.0, positive=False),
        position_m_per_count=cal_t.num("position_m_per_count"),
        position_offset_m=cal_t.num("position_offset_m", 0.0, positive=False),
        temperature_c_per_count=cal_t.num("temperature_c_per_count"),
        temperature_offset_c=cal_t.num("temperature_offset_c", 0.0, positive=False),
    )
    cal_t.check_unknown()
    daq = DaqConfig(
        url=daq_t.str_("url"),
        baudrate=daq_t.int_("baudrate", 921600, lo=300, hi=20_000_000),
        sample_rate_hz=daq_t.num("sample_rate_hz"),
        calibration=cal,
        frozen_timeout_s=daq_t.num("frozen_timeout_s", 0.5),
        max_gap_s=daq_t.num("max_gap_s", 0.05),
        max_frame_loss=daq_t.num("max_frame_loss", 0.01, positive=False),
    )
    if not 0 <= daq.max_frame_loss < 1:
        raise daq_t.fail("max_frame_loss", "must be 0-1 (a fraction of the test's frames)")
    bits_per_s = daq.sample_rate_hz * 18 * 10  # 18-byte frames, 10 bits per byte on the wire
    if not daq.url.startswith(("socket://", "loop://")) and bits_per_s > daq.baudrate:
        raise daq_t.fail(
            "baudrate",
            f"{daq.baudrate} baud cannot carry {daq.sample_rate_hz:g} frames/s "
            f"(needs {bits_per_s:.0f})",
        )

    lim_t = top.table("limits")
    limits = Limits(
        travel_m=lim_t.num("travel_m"),
        force_n=lim_t.num("force_n"),
        velocity_m_s=lim_t.num("velocity_m_s"),
        temperature_c=lim_t.num("temperature_c"),
        trip_margin=lim_t.num("trip_margin", 0.05, positive=False),
    )
    lim_t.check_unknown()
    if not 0 <= limits.trip_margin < 1:
        raise lim_t.fail("trip_margin", "must be 0-1")
    daq = replace(
        daq,
        position_range_m=_range(
            daq_t, "position_range_m", (centre - 4 * limits.travel_m, centre + 4 * limits.travel_m)
        ),
        force_range_n=_range(daq_t, "force_range_n", (-4 * limits.force_n, 4 * limits.force_n)),
        temperature_range_c=_range(daq_t, "temperature_range_c", (-40.0, 200.0)),
    )
    daq_t.check_unknown()

    ramp_t = top.table("ramp", required=False)
    ramp = RampConfig(
        sine_ramp_cycles=ramp_t.int_("sine_ramp_cycles", 1, lo=1, hi=100),
        move_velocity_m_s=ramp_t.num("move_velocity_m_s", 0.01),
        stop_time_s=ramp_t.num("stop_time_s", 0.5),
    )
    ramp_t.check_unknown()
    hb_t = top.table("heartbeat", required=False)
    hb = HeartbeatConfig(period_s=hb_t.num("period_s", 0.1), timeout_s=hb_t.num("timeout_s", 0.5))
    hb_t.check_unknown()
    if hb.timeout_s < 2 * hb.period_s:
        raise hb_t.fail("timeout_s", "must be at least twice period_s")
    if hb.timeout_s * 1000 > 65535:
        raise hb_t.fail("timeout_s", "must be below 65.5 s (a uint16 of milliseconds)")

    ver_t = top.table("verify", required=False)
    verify = VerifyConfig(
        frequency_tolerance=ver_t.num("frequency_tolerance", 0.01),
        amplitude_tolerance=ver_t.num("amplitude_tolerance", 0.05),
        centre_tolerance_m=ver_t.num("centre_tolerance_m", 0.001),
    )
    ver_t.check_unknown()

    sim = top.raw("simulation", {})
    if not isinstance(sim, dict):
        raise top.fail("simulation", "must be a table")
    top.check_unknown()
    return RigConfig(
        name=name,
        source=source,
        actuator=transport,
        registers=regs,
        daq=daq,
        limits=limits,
        stroke_centre_m=centre,
        adjuster=adjuster,  # type: ignore[arg-type]
        ramp=ramp,
        heartbeat=hb,
        poll_period_s=poll,
        verify=verify,
        simulation=dict(sim),
        raw_toml=text,
    )


def default_rig_path() -> Path:
    """rigs/sim.toml of this checkout, else of the current directory."""
    here = Path(__file__).resolve().parents[3] / "rigs" / "sim.toml"
    return here if here.exists() else Path("rigs/sim.toml")


def load_rig(path: str | Path) -> RigConfig:
    """Read and validate a rig file; every problem is a one-line ConfigError."""
    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise ConfigError(f"rig file not found: {p}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: cannot read ({exc})") from None
    return parse_rig(text, str(p))
