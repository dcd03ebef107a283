"""The simulated drive's Modbus face: register reads and writes <-> SimDrive / SimEngine."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from pymodbus.constants import ExcCodes

from shockdyno.errors import ConfigError
from shockdyno.rig.config import RegisterMap
from shockdyno.rig.registers import decode, encode
from shockdyno.simrig.engine import SimEngine


class DriveRegisters:
    """Maps register names to the drive's state. All calls run on the sim-rig's event loop."""

    def __init__(self, engine: SimEngine, rm: RegisterMap, clock: Callable[[], float]) -> None:
        self.engine = engine
        self.map = rm
        self.clock = clock
        self.control_word = 0
        self.heartbeat = 0
        self.last_beat_wall = clock()
        # Every control word written, with the clock time it arrived: what an independent
        # observer of the wire sees (benchmarks/bench_faults.py times the stop command).
        self.control_log: deque[tuple[float, int]] = deque(maxlen=4096)
        self.start, self.count = rm.span
        self._owner: dict[int, str] = {}
        for reg in rm.registers.values():
            for a in range(reg.address, reg.address + reg.width):
                self._owner[a] = reg.name

    # -- reads -------------------------------------------------------------------------
    def value(self, name: str) -> float:
        """A register's engineering value now (SI or a count), read from the simulated drive and
        engine; 0 for one it does not model."""
        e = self.engine
        d = e.drive
        t = e.now_s
        if name == "status_word":
            bits = d.status_bits(t)
            return float(sum(1 << b for k, b in self.map.status_bits.items() if bits.get(k)))
        values: dict[str, float] = {
            "control_word": self.control_word,
            "mode": d.mode,
            "fault_code": d.fault_code,
            "heartbeat": self.heartbeat,
            "heartbeat_timeout_ms": d.heartbeat_timeout_ms,
            "rod_clicks": e.state.clicks[0],
            "gas_clicks": e.state.clicks[1],
            "position_command": d.position_command_m,
            "position_actual": d.position_m,
            "move_velocity": d.move_velocity_m_s,
            "sine_amplitude": d.sine_amplitude_m,
            "sine_frequency": d.sine_frequency_hz,
            "sine_centre": d.sine_centre_m,
            "sine_cycles": d.sine_cycles,
            "sine_ramp_cycles": d.sine_ramp_cycles,
            "force_actual": d.last_force_n,
            "cycle_count": d.cycle_count(t),
            "travel_limit": d.params.travel_m,
            "velocity_limit": d.params.velocity_limit_m_s,
            "force_limit": d.params.force_capacity_n,
            "waveform": d.waveform,
            "waveform_acceleration": d.waveform_accel_m_s2,
            "acceleration_limit": d.params.accel_limit_m_s2,
        }
        if name.endswith("_clicks") and name[: -len("_clicks")] in e.state.setting:
            return float(e.state.setting[name[: -len("_clicks")]])
        return float(values.get(name, 0.0))

    def refresh(self, registers: list[int], block_start: int) -> None:
        """Encode every register's value now into `registers` (the block starting at
        `block_start`)."""
        wo = self.map.word_order
        for reg in self.map.registers.values():
            try:
                words = encode(reg, self.value(reg.name), wo)
            except ConfigError:
                continue
            off = reg.address - block_start
            registers[off : off + reg.width] = words

    # -- writes ------------------------------------------------------------------------
    def only_heartbeat(self, address: int, count: int) -> bool:
        """Whether a write of `count` words at `address` touches the heartbeat alone (the
        one write that does not reach the engine's state)."""
        return all(self._owner.get(a) == "heartbeat" for a in range(address, address + count))

    def write(
        self, registers: list[int], block_start: int, address: int, values: list[int]
    ) -> ExcCodes | None:
        """A host's write of `values` at `address`: the words merged and each touched register
        acted on (control bits, setpoints, clicks); the Modbus exception for a word outside any
        writable register or a value the drive refuses, else None."""
        touched: list[str] = []
        for a in range(address, address + len(values)):
            name = self._owner.get(a)
            if name is None or not self.map[name].writable:
                return ExcCodes.ILLEGAL_ADDRESS
            if name not in touched:
                touched.append(name)
        merged = list(registers)
        merged[address - block_start : address - block_start + len(values)] = values
        for name in touched:
            reg = self.map[name]
            off = reg.address - block_start
            value = decode(reg, merged[off : off + reg.width], self.map.word_order)
            err = self._apply(name, value)
            if err is not None:
                return err
        return None

    def _apply(self, name: str, value: float) -> ExcCodes | None:
        e = self.engine
        d = e.drive
        t = e.now_s
        if name == "control_word":
            self._control(int(value), t)
        elif name == "heartbeat":
            if int(value) != self.heartbeat:
                self.heartbeat = int(value)
                self.last_beat_wall = self.clock()
        elif name == "mode":
            if int(value) not in self.map.modes.values():
                return ExcCodes.ILLEGAL_VALUE
            d.mode = int(value)
        elif name in ("rod_clicks", "gas_clicks"):
            rod, gas = e.state.clicks
            rod, gas = (int(value), gas) if name == "rod_clicks" else (rod, int(value))
            try:
                if name == "gas_clicks" and e.state.setting:  # keep the adjusters' own
                    e.set_gas(gas)
                else:
                    e.set_clicks(rod, gas)
            except ConfigError:
                return ExcCodes.ILLEGAL_VALUE
        elif name.endswith("_clicks") and name[: -len("_clicks")] in e.state.setting:
            try:
                e.set_adjuster(name[: -len("_clicks")], int(value))
            except ConfigError:
                return ExcCodes.ILLEGAL_VALUE
        elif name == "position_command":
            d.position_command_m = value
            speed = d.move_velocity_m_s if d.mode == self.map.modes.get("hold", 0) else 10.0
            d.move(t, value, min(speed, d.params.velocity_limit_m_s))
        else:
            attr = {
                "heartbeat_timeout_ms": "heartbeat_timeout_ms",
                "move_velocity": "move_velocity_m_s",
                "sine_amplitude": "sine_amplitude_m",
                "sine_frequency": "sine_frequency_hz",
                "sine_centre": "sine_centre_m",
                "sine_cycles": "sine_cycles",
                "sine_ramp_cycles": "sine_ramp_cycles",
                "waveform": "waveform",
                "waveform_acceleration": "waveform_accel_m_s2",
            }.get(name)
            if attr is None:
                return ExcCodes.ILLEGAL_ADDRESS
            current = getattr(d, attr)
            setattr(d, attr, int(value) if isinstance(current, int) else float(value))
        return None

    def _control(self, word: int, t: float) -> None:
        self.control_word = word
        self.control_log.append((self.clock(), word))
        bits = self.map.control_bits
        d = self.engine.drive

        def on(name: str) -> bool:
            return bool(word >> bits[name] & 1) if name in bits else False

        if on("fault_reset"):
            d.fault_reset()
        if on("enable") and not d.enabled:
            self.last_beat_wall = self.clock()  # a fresh watchdog period
            d.enable(t)
        elif not on("enable") and d.enabled:
            d.disable(t)
        if on("quick_stop"):
            d.stop(t, quick=True)
        elif on("stop"):
            d.stop(t)
        if on("start"):
            d.start(t)
