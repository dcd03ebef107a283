"""The simulated rig's physics and sensors: samples in, DAQ frame bytes out. No I/O.

`SimEngine.advance(n)` produces the next n samples (n a multiple of CHUNK) of the servo,
the damper and the sensors, vectorised, and returns them as DAQ frames. Everything that
carries state (servo filter, derivatives, physics terms, sensor lags, one RNG stream per
sensor) continues exactly across calls, so a run split into any batches gives the same
bytes: the sim-rig's speed changes only how often `advance` is called.

Drive trips (over-force, over-velocity, travel) act at the end of the chunk in which
they happen, like a drive's monitoring cycle: the batch is rewound to that chunk and the
rest recomputed with the drive stopping.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Annotated

import numpy as np
from msgspec import Meta
from numpy.typing import NDArray

from shockdyno.errors import ConfigError
from shockdyno.model.composite import DamperModel, ModelInputs, Term
from shockdyno.model.filters import biquad, first_order_lag
from shockdyno.model.spec import DamperSpec
from shockdyno.rig.config import RigConfig
from shockdyno.rig.frames import FRAME_LEN, STATUS_MOTION, encode_frames
from shockdyno.schema import NonNegative, Positive, convert, fail
from shockdyno.simrig.drive import (
    DRIVE_FAULT,
    OVER_FORCE,
    OVER_VELOCITY,
    TRAVEL_LIMIT,
    DriveParams,
    SimDrive,
)
from shockdyno.simrig.faults import Fault
from shockdyno.simrig.reference import PlantParams, PlantState, ReferencePlant

_ONE_SEGMENT = np.zeros(1, dtype=np.intp)
CHUNK = 10  # samples: the grid on which commands, faults and trips take effect
FloatArray = NDArray[np.float64]


def servo_filter(bandwidth_hz: float, damping: float, fs: float) -> tuple[FloatArray, FloatArray]:
    """(b, a) of the servo's second-order response wn²/(s² + 2ζ wn s + wn²), by the
    bilinear transform at fs (scipy.signal.bilinear's, without importing scipy.signal)."""
    wn = 2 * math.pi * bandwidth_hz
    k = 2.0 * fs
    a0 = k * k + 2 * damping * wn * k + wn * wn
    b = np.array([1.0, 2.0, 1.0]) * wn * wn / a0
    a = np.array([a0, 2 * (wn * wn - k * k), k * k - 2 * damping * wn * k + wn * wn]) / a0
    return b, a


def at_rest(b: FloatArray, a: FloatArray, x0: float) -> FloatArray:
    """The filter's state when input and output have stood at x0 (scipy.signal.lfiltic's
    with both histories x0)."""
    return np.array([(b[1] + b[2] - a[1] - a[2]) * x0, (b[2] - a[2]) * x0])


@dataclass
class SimParams:
    """The rig file's [simulation] table (read through shockdyno.schema)."""

    initial_position_m: float  # absolute (the LVDT's), as rig.stroke_centre_m
    servo_bandwidth_hz: Positive = 60.0
    servo_damping: Positive = 0.8
    drive_force_capacity_n: Positive = 12000.0
    drive_velocity_limit_m_s: Positive = 0.8
    drive_travel_m: Positive = 0.05
    drive_acceleration_limit_m_s2: Positive = 50.0  # the most a reversal may ask of the drive
    force_noise_n: NonNegative = 2.0
    position_noise_m: NonNegative = 1e-6
    temperature_noise_c: NonNegative = 0.02
    ambient_c: Annotated[float, Meta(ge=-273.15)] = 40.0
    # What the load cell reads with no force on it (its zero drift): `shockdyno rig tare`
    # must find it; any sign.
    load_cell_offset_n: float = 0.0
    jam_force_n: float = 0.0  # set by the over-force fault, never by the file

    @staticmethod
    def from_rig(rig: RigConfig) -> SimParams:
        """The rig file's [simulation] table checked (the initial position defaults to the stroke
        centre and must lie within the drive's travel of it); ConfigError naming the key."""
        data = dict(rig.simulation)
        if "jam_force_n" in data:
            raise fail(rig.source, "simulation.jam_force_n", "unknown key (a fault sets it)")
        data.setdefault("initial_position_m", rig.stroke_centre_m)
        p = convert(data, SimParams, rig.source, "simulation")
        if abs(p.initial_position_m - rig.stroke_centre_m) > p.drive_travel_m:
            raise fail(
                rig.source,
                "simulation.initial_position_m",
                f"{p.initial_position_m:g} m is beyond drive_travel_m ({p.drive_travel_m:g} m) "
                f"of the stroke centre ({rig.stroke_centre_m:g} m)",
            )
        return p


@dataclass
class _State:
    drive: SimDrive
    servo_zi: FloatArray
    x_hist: tuple[float, float, float]  # the last three ram positions, oldest first
    lvdt_zi: FloatArray | None
    term_state: dict[str, FloatArray]
    rng_force: np.random.Generator
    rng_pos: np.random.Generator
    rng_temp: np.random.Generator
    rng_fault: np.random.Generator
    faults: list[Fault]
    frozen: bool = False
    pending_garble: int = 0
    pending_drop: int = 0
    jam_start: float = 0.0
    jam_until: float = -1.0
    clicks: tuple[int, int] = (10, 0)
    setting: dict[str, int] = field(default_factory=dict)  # a damper's own adjusters, by name
    areas: tuple[float, float] = (0.0, 0.0)
    temperature_c: float = 40.0
    plant: PlantState | None = None
    # faults of the wires, for the server to act on ("server_faults")
    extra: dict[str, list[Fault]] = field(default_factory=dict)


class SimEngine:
    """The simulated rig's physics, sample by sample on the DAQ's clock: the drive's profile
    through a second-order servo, the damper's force (the library's model with the scenario's
    terms, or the reference plant), sensor noise and the frames the DAQ sends, with faults
    injected on schedule; its noise from `seed`."""

    def __init__(
        self,
        rig: RigConfig,
        spec: DamperSpec,
        *,
        terms: list[Term] | None = None,
        term_values: dict[str, float] | None = None,
        lvdt_lag_s: float = 0.0,
        seed: int = 0,
        faults: list[Fault] | None = None,
        plant: PlantParams | None = None,
    ) -> None:
        self.rig = rig
        self.spec = spec
        self.model = DamperModel(spec, tuple(terms or ()), dict(term_values or {}))
        self.params = SimParams.from_rig(rig)
        self.fs = rig.daq.sample_rate_hz
        if plant is not None and spec.adjusters:
            raise ConfigError(
                f"the reference plant has the one rod needle; the damper {spec.name} has "
                f"adjusters {', '.join(spec.adjuster_names)} (use a scenario without [plant])"
            )
        self.plant = ReferencePlant(spec, plant, self.fs) if plant is not None else None
        # Samples per step of the server's loop. The reference plant's compiled implicit
        # steps take 0.1-0.4 ms a sample (8 sub-steps each) and run in a thread of their
        # own (server.py), but a command waits for the step under way: 100 samples keep a
        # step near 0.04 s, well under the rig file's 0.5 s Modbus timeout even at 5x that.
        self.max_batch = 5000 if self.plant is None else 100
        self.min_batch = CHUNK
        self.cal = rig.daq.calibration
        self.centre = rig.stroke_centre_m
        p = self.params
        self._servo_b, self._servo_a = servo_filter(p.servo_bandwidth_hz, p.servo_damping, self.fs)
        x0 = p.initial_position_m
        zi = at_rest(self._servo_b, self._servo_a, x0)
        self._lvdt_lag_s = float(lvdt_lag_s)
        drive = SimDrive(
            DriveParams(
                centre_m=self.centre,
                travel_m=p.drive_travel_m,
                force_capacity_n=p.drive_force_capacity_n,
                velocity_limit_m_s=p.drive_velocity_limit_m_s,
                accel_limit_m_s2=p.drive_acceleration_limit_m_s2,
            ),
            position_m=x0,
        )
        ss = np.random.SeedSequence(seed)
        rngs = [np.random.default_rng(s) for s in ss.spawn(4)]
        self.state = _State(
            drive=drive,
            servo_zi=np.asarray(zi, float),
            x_hist=(x0, x0, x0),
            lvdt_zi=None,
            term_state={},
            rng_force=rngs[0],
            rng_pos=rngs[1],
            rng_temp=rngs[2],
            rng_fault=rngs[3],
            faults=sorted(faults or [], key=lambda f: f.at_s),
            temperature_c=p.ambient_c,
        )
        if self.plant is not None:
            self.state.plant = self.plant.initial(x0 - self.centre, p.ambient_c)
        self.set_clicks(10, 0)
        self.produced = 0  # samples produced so far (the DAQ's sequence counter)
        self.frames_sent = 0
        self.frames_dropped = 0
        self.frames_garbled = 0

    # -- commands from the Modbus side ----------------------------------------------------
    @property
    def drive(self) -> SimDrive:
        """The simulated drive's state machine."""
        return self.state.drive

    @property
    def now_s(self) -> float:
        """Sim time of the next sample: when a command received now takes effect."""
        return self.produced / self.fs

    def set_clicks(self, rod: int, gas: int) -> None:
        """The rod needle's clicks (every adjuster at them, on a damper with several)."""
        a_bc, a_bt = self.spec.bleed_areas(rod, gas)  # ConfigError if out of range
        self.state.clicks = (rod, gas)
        self.state.areas = (float(a_bc), float(a_bt))
        self.state.setting = {
            a.name: min(rod, self.spec.adjuster_law(a.name).max_clicks) for a in self.spec.adjusters
        }
        if self.spec.adjusters:
            self._set(self.state.setting, gas)

    def set_adjuster(self, name: str, clicks: int) -> None:
        """One adjuster of a damper with several: its path's area follows (ConfigError for
        an adjuster the damper has not, or clicks out of its range)."""
        self._set({**self.state.setting, name: clicks}, self.state.clicks[1])

    def set_gas(self, gas: int) -> None:
        """The gas bottle of a damper with several adjusters, which keep their clicks."""
        self._set(self.state.setting, gas)

    def _set(self, setting: dict[str, int], gas: int) -> None:
        a_bc, a_bt = self.spec.setting_areas(setting, gas)  # ConfigError if out of range
        self.state.setting = setting
        self.state.clicks = (self.state.clicks[0], gas)
        self.state.areas = (a_bc, a_bt)

    def inject(self, fault: Fault) -> None:
        """Apply a fault at the next sample (fault.at_s is ignored)."""
        self._activate(fault, self.now_s)

    # -- production -----------------------------------------------------------------------
    def advance(self, n: int) -> bytes:
        """The next n samples as frame bytes (n is rounded up to whole chunks)."""
        n = -(-n // CHUNK) * CHUNK
        out: list[bytes] = []
        while n > 0:
            t_now = self.now_s
            st = self.state
            while st.faults and st.faults[0].at_s <= t_now + 1e-12:
                self._activate(st.faults.pop(0), t_now)
            st.drive.tick(t_now)
            m = n
            if st.faults:  # stop the batch at the next scheduled fault's chunk
                k = math.ceil((st.faults[0].at_s - t_now) * self.fs / CHUNK) * CHUNK
                m = min(m, max(k, CHUNK))
            if st.drive.disable_at is not None:
                k = math.ceil((st.drive.disable_at - t_now) * self.fs / CHUNK) * CHUNK
                m = min(m, max(k, CHUNK))
            out.append(self._batch(m))
            n -= m
        return b"".join(out)

    def _batch(self, n: int) -> bytes:
        saved = copy.deepcopy(self.state) if self.state.drive.enabled else None
        produced = self.produced
        result = self._compute(n)
        trip = result[1]
        if trip is None or saved is None:
            return self._emit(*result[0])
        code, k = trip
        keep = (k // CHUNK + 1) * CHUNK
        if keep < n:  # rewind and redo up to the end of the tripping chunk
            self.state, self.produced = saved, produced
            result = self._compute(keep)
        frames = self._emit(*result[0])
        self.state.drive.trip(code, self.now_s)
        if keep < n:
            frames += self._batch(n - keep)
        return frames

    def _compute(
        self, n: int
    ) -> tuple[
        tuple[NDArray[np.int64], FloatArray, FloatArray, FloatArray, NDArray[np.uint16]],
        tuple[int, int] | None,
    ]:
        st = self.state
        p = self.params
        seq = self.produced + np.arange(n, dtype=np.int64)
        t = seq / self.fs
        drv = st.drive
        x_cmd = drv.command(t)
        x, st.servo_zi = biquad(self._servo_b, self._servo_a, x_cmd, st.servo_zi)
        v, a = _backward_derivatives(x, st.x_hist, self.fs)
        st.x_hist = _tail(st.x_hist, x)
        rel = x - self.centre
        a_bc, a_bt = st.areas
        sensed: tuple[FloatArray, FloatArray] | None = None
        if self.plant is not None and st.plant is not None:
            force, f_sensed, x_sensed, temp, st.plant = self.plant.run(
                t, rel, v, a, st.clicks, st.plant, p.ambient_c
            )
            sensed = (f_sensed - force, x_sensed - rel)  # what the sensor chain adds
        else:
            ev = self.model.evaluate(
                ModelInputs.single(rel, v, a, 1.0 / self.fs), a_bc, a_bt, state=st.term_state
            )
            st.term_state = ev.state
            force = ev.force
            temp = ev.outputs.get("thermal.temperature_c", np.full(n, p.ambient_c))
        if st.jam_until > t[0]:
            ramp = np.clip((t - st.jam_start) / 0.2, 0.0, 1.0)
            force = force + np.where(t < st.jam_until, p.jam_force_n * ramp, 0.0)
        drv.position_m = float(x[-1])
        drv.last_force_n = float(force[-1])
        st.temperature_c = float(temp[-1])
        trip = None
        if drv.enabled and not drv.fault_code:
            checks = (
                (OVER_FORCE, np.abs(force) > p.drive_force_capacity_n),
                (OVER_VELOCITY, np.abs(v) > p.drive_velocity_limit_m_s),
                (TRAVEL_LIMIT, np.abs(rel) > p.drive_travel_m),
            )
            firsts = [(int(np.argmax(m)), code) for code, m in checks if m.any()]
            if firsts:
                k, code = min(firsts)
                trip = (code, k)
        # sensors
        pos = x
        if self._lvdt_lag_s > 0:
            # The same first-order lag the model's terms use (exact for a ramp between
            # samples; a one-pole y += k (x - y) at τ = dt delays by 0.58 ms, not 1 ms).
            pos, st.lvdt_zi = first_order_lag(
                x, self._lvdt_lag_s, _ONE_SEGMENT, np.array([1.0 / self.fs]), st.lvdt_zi
            )
        f_meas = force
        if sensed is not None:
            f_meas = f_meas + sensed[0]
            pos = pos + sensed[1]
        pos = pos + p.position_noise_m * st.rng_pos.standard_normal(n)
        f_meas = f_meas + p.load_cell_offset_n + p.force_noise_n * st.rng_force.standard_normal(n)
        t_meas = temp + p.temperature_noise_c * st.rng_temp.standard_normal(n)
        status = np.where(drv.motion(t), STATUS_MOTION, 0).astype(np.uint16)
        self.produced += n
        return (seq, pos, f_meas, t_meas, status), trip

    def _emit(
        self,
        seq: NDArray[np.int64],
        pos: FloatArray,
        force: FloatArray,
        temp: FloatArray,
        status: NDArray[np.uint16],
    ) -> bytes:
        st = self.state
        cal = self.cal
        load = np.clip(np.round((force - cal.force_offset_n) / cal.force_n_per_count), -2e9, 2e9)
        lvdt = np.clip(
            np.round((pos - cal.position_offset_m) / cal.position_m_per_count), -2e9, 2e9
        )
        tc = np.clip(
            np.round((temp - cal.temperature_offset_c) / cal.temperature_c_per_count),
            -32768,
            32767,
        )
        if st.frozen:  # the DAQ has hung: the counter and the line stop
            return b""
        data = encode_frames(
            seq, load.astype(np.int32), lvdt.astype(np.int32), tc.astype(np.int16), status
        )
        if not (st.pending_drop or st.pending_garble):
            self.frames_sent += len(seq)
            return data
        frames = [data[i : i + FRAME_LEN] for i in range(0, len(data), FRAME_LEN)]
        kept: list[bytes] = []
        for fr in frames:
            if st.pending_drop:
                st.pending_drop -= 1
                self.frames_dropped += 1
                continue
            if st.pending_garble:
                st.pending_garble -= 1
                self.frames_garbled += 1
                b = bytearray(fr)
                i = int(st.rng_fault.integers(0, FRAME_LEN))
                b[i] ^= int(st.rng_fault.integers(1, 256))
                fr = bytes(b) + bytes(st.rng_fault.integers(0, 256, 3, dtype=np.uint8))
            kept.append(fr)
        self.frames_sent += len(kept)
        return b"".join(kept)

    # -- faults -----------------------------------------------------------------------------
    def _activate(self, fault: Fault, t: float) -> None:
        st = self.state
        if fault.kind == "garble":
            st.pending_garble += fault.count
        elif fault.kind == "drop":
            st.pending_drop += fault.count
        elif fault.kind == "freeze":
            st.frozen = True
        elif fault.kind == "actuator_fault":
            st.drive.trip(DRIVE_FAULT, t)
        elif fault.kind == "over_force":
            self.params.jam_force_n = fault.force_n
            st.jam_start = t
            st.jam_until = t + (fault.duration_s or 0.5)
        else:  # faults of the wires (modbus_timeout, daq_disconnect) are the server's
            st.extra.setdefault("server_faults", []).append(fault)


def _backward_derivatives(
    x: FloatArray, hist: tuple[float, float, float], fs: float
) -> tuple[FloatArray, FloatArray]:
    """Velocity and acceleration at each sample's own time, from it and earlier samples.

    A first-order backward difference is the velocity half a sample earlier: a 0.5 ms lag
    between force and displacement that no clean rig has. The second-order formulas
    v = (3x₀ - 4x₋₁ + x₋₂)/2h and a = (2x₀ - 5x₋₁ + 4x₋₂ - x₋₃)/h² are causal (the stream
    cannot look ahead) and carry no lag; their O(h²) error is negligible on the smooth
    servo output.
    """
    ext = np.concatenate([np.asarray(hist, float), x])
    v = (3 * ext[3:] - 4 * ext[2:-1] + ext[1:-2]) * (fs / 2)
    a = (2 * ext[3:] - 5 * ext[2:-1] + 4 * ext[1:-2] - ext[:-3]) * fs**2
    return v, a


def _tail(hist: tuple[float, float, float], x: FloatArray) -> tuple[float, float, float]:
    last = [*hist, *(float(v) for v in x[-3:])][-3:]
    return (last[0], last[1], last[2])
