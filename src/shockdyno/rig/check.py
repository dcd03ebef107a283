"""`rig check`: what a rig's drive and DAQ say, read only. Nothing is written to the drive.

First contact with hardware must not be a command that enables the drive and moves the
ram. This reads every register the project uses (one at a time, so a register the drive
refuses is named), the span RigSession polls, and about a second of DAQ frames, and
judges each value against the rig file: position within the travel, status bits, the
frame rate, lost or damaged frames, the load cell, LVDT and thermometer readings.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from shockdyno.errors import RigFault
from shockdyno.rig.actuator import STATUS_NAMES, ModbusActuator
from shockdyno.rig.config import DaqConfig, Limits, RigConfig
from shockdyno.rig.daq import SerialDaq
from shockdyno.rig.frames import (
    STATUS_LOAD_OVERRANGE,
    STATUS_LVDT_OVERRANGE,
    STATUS_MOTION,
    STATUS_TEMP_FAULT,
)
from shockdyno.samples import SampleBlock

RATE_TOLERANCE = 0.05  # measured on the host's clock over ~1 s, where reads jitter by ms
POSITION_AGREEMENT_M = 0.001  # LVDT vs the drive's own position (as CENTRE_TOLERANCE_M)
AT_REST_SD_M = 1e-4  # an LVDT at rest that varies more: the ram moves, or the LVDT is noisy


@dataclass
class Finding:
    """One line of the check: what was read, and whether it is fine for a sweep."""

    what: str
    value: str
    ok: bool = True
    note: str = ""

    def as_dict(self) -> dict[str, object]:  # `rig check --json`
        """The finding as `rig check --json` writes it."""
        return {"what": self.what, "value": self.value, "ok": self.ok, "note": self.note}


@dataclass
class DaqListen:
    """About a second of DAQ frames, with the decoder's counts and the rate on the host clock."""

    samples: SampleBlock
    frames: int
    dropped: int
    corrupt: int
    rejected: int
    garbage_bytes: int
    rate_hz: float  # frames per host second (nan when too few reads brought frames)
    seconds: float


@dataclass
class CheckResult:
    """`rig check`'s result: one Finding a line for the drive and for the DAQ."""

    rig: str
    source: str
    drive: list[Finding] = field(default_factory=list)
    daq: list[Finding] = field(default_factory=list)

    @property
    def problems(self) -> list[str]:
        """One line for each finding that is not fine for a sweep."""
        return [f"{f.what}: {f.note or f.value}" for f in (*self.drive, *self.daq) if not f.ok]

    @property
    def ok(self) -> bool:
        """Whether nothing the check read stands in a sweep's way."""
        return not self.problems

    def as_dict(self) -> dict[str, object]:  # `rig check --json`
        """The result as `rig check --json` writes it."""
        return {
            "rig": self.rig,
            "source": self.source,
            "ok": self.ok,
            "problems": self.problems,
            "drive": [f.as_dict() for f in self.drive],
            "daq": [f.as_dict() for f in self.daq],
        }


# -- reading -------------------------------------------------------------------------------


def open_links(rig: RigConfig) -> tuple[ModbusActuator, SerialDaq]:
    """Connect to the drive and open the DAQ; both failures are named in one RigFault line."""
    act = ModbusActuator(rig)
    failed: list[str] = []
    daq: SerialDaq | None = None
    try:
        act.connect()
    except RigFault as exc:
        failed.append(f"drive not reachable: {exc}")
    else:
        try:  # a port that accepts connections need not be a Modbus drive: one read proves it
            act.read(["status_word"])
        except RigFault as exc:
            failed.append(
                f"drive not answering (connected, but no Modbus reply: wrong port, device_id "
                f"or framing?): {exc}"
            )
    try:
        daq = SerialDaq(rig.daq, rig.stroke_centre_m)
    except RigFault as exc:
        failed.append(str(exc))
    if failed:
        act.close()
        if daq is not None:
            daq.close()
        raise RigFault("; ".join(failed))
    assert daq is not None
    return act, daq


def listen(
    daq: SerialDaq, seconds: float, clock: Callable[[], float] = time.monotonic
) -> DaqListen:
    """Read the DAQ for `seconds` of host time. The rate is the slope of the last sequence
    number of each read against the host time it arrived: a backlog waiting at the start,
    a late read or a burst moves single points, not the slope, and lost frames do not
    lower it (the counter counts them)."""
    blocks: list[SampleBlock] = []
    arrivals: list[tuple[float, int]] = []
    start = clock()
    while clock() - start < seconds:
        block = daq.read()
        if not len(block):
            continue
        blocks.append(block)
        arrivals.append((clock(), int(block.seq[-1])))
    rate = math.nan
    # The first read may hold the backlog of the connection: the slope starts after it.
    if len(arrivals) > 10 and arrivals[-1][0] - arrivals[1][0] > 0.25 * seconds:
        t, seq = np.array(arrivals[1:], dtype=float).T
        rate = float(np.polyfit(t - t[0], seq - seq[0], 1)[0])
    samples = SampleBlock.concat(blocks) if blocks else SampleBlock.empty()
    return DaqListen(
        samples=samples,
        frames=daq.frames,
        dropped=daq.dropped_frames,
        corrupt=daq.corrupt_frames,
        rejected=daq.rejected_frames,
        garbage_bytes=daq.garbage_bytes,
        rate_hz=rate,
        seconds=seconds,
    )


# -- judging -------------------------------------------------------------------------------


def _mm(x_m: float) -> str:
    return f"{x_m * 1e3:+.2f} mm"


def check_registers(act: ModbusActuator, rig: RigConfig) -> tuple[list[Finding], float | None]:
    """Every register of the map, read one by one; the drive's position (m, absolute)."""
    rm = rig.registers
    out: list[Finding] = []
    values: dict[str, float] = {}
    for name, reg in sorted(rm.registers.items(), key=lambda kv: kv[1].address):
        what = f"register {name} @{reg.address} ({reg.type})"
        try:
            values[name] = act.read([name])[name]
        except RigFault as exc:
            out.append(Finding(what, "unreadable", False, f"read refused or failed: {exc}"))
            continue
        out.append(Finding(what, f"{values[name]:g}"))
    # RigSession reads the status and every setpoint it wrote in one request each poll.
    polled = [n for n in (*STATUS_NAMES, "heartbeat_timeout_ms", "sine_amplitude",
                          "sine_frequency", "sine_centre", "sine_cycles", "sine_ramp_cycles",
                          "rod_clicks", "gas_clicks") if n in rm]  # fmt: skip
    try:
        act.status(polled)
        out.append(Finding("status poll (one read of the span a session polls)", "ok"))
    except RigFault as exc:
        out.append(
            Finding("status poll", "failed", False, f"a sweep polls these in one read: {exc}")
        )
    out.extend(_judge_registers(values, rig))
    pos = values.get("position_actual")
    return out, pos


def _judge_registers(values: dict[str, float], rig: RigConfig) -> list[Finding]:
    rm = rig.registers
    out: list[Finding] = []
    if "status_word" in values:
        word = int(values["status_word"])
        bits = {k: bool(word >> b & 1) for k, b in rm.status_bits.items()}
        on = ", ".join(k for k, v in bits.items() if v) or "none"
        f = Finding("status bits", f"0x{word:04x} ({on})")
        if bits.get("fault"):
            code = int(values.get("fault_code", 0))
            f.ok, f.note = False, f"drive in fault: {rm.fault_text(code)}"
        elif bits.get("running"):
            f.ok, f.note = False, "drive reports running: something is moving the ram"
        elif bits.get("enabled"):
            f.ok, f.note = False, "drive is enabled (another master or its panel holds it)"
        elif not bits.get("ready", True):
            f.ok, f.note = False, "drive is not ready"
        out.append(f)
    if "fault_code" in values and int(values["fault_code"]):
        code = int(values["fault_code"])
        out.append(Finding("fault code", str(code), False, rm.fault_text(code)))
    if "mode" in values and int(values["mode"]) not in rm.modes.values():
        out.append(Finding("mode", f"{values['mode']:g}", False, "not a mode of the rig file"))
    if "position_actual" in values:
        x = values["position_actual"] - rig.stroke_centre_m
        f = Finding("drive position", f"{_mm(x)} from centre")
        if not math.isfinite(x) or abs(x) > rig.limits.travel_m:
            f.ok = False
            f.note = (
                f"{_mm(x)} from centre is outside the travel ±{rig.limits.travel_m * 1e3:g} mm "
                f"(limits.travel_m; check stroke_centre_m and the register's scale)"
            )
        out.append(f)
    return out


def _share(status: np.ndarray, bit: int) -> float:
    return float(np.mean((status & bit) != 0)) if status.size else 0.0


def check_daq(got: DaqListen, rig: RigConfig, drive_position_m: float | None) -> list[Finding]:
    """What the DAQ sent with the drive at rest: its frames, then each sensor's reading."""
    s = got.samples
    if not len(s):
        why = f"no valid frame from {rig.daq.url} in {got.seconds:g} s"
        return [Finding("frames", f"{got.frames} valid in {got.seconds:g} s", False, why)]
    return [
        *_stream(got, rig.daq),
        _load_cell(s, rig.limits),
        *_lvdt(s, rig, drive_position_m),
        _temperature(s, rig.daq, rig.limits),
        _motion_input(s),
    ]


def _stream(got: DaqListen, cfg: DaqConfig) -> list[Finding]:
    """Frames received, their rate against the rig file's, and the frames lost."""
    # As the session checks before enabling: a simulated rig's time scale counts.
    nominal, scale = cfg.frames_per_host_s, cfg.time_scale_note
    rate = Finding("frame rate", f"{got.rate_hz:.0f} frames/s (rig file: {nominal:g}{scale})")
    if not math.isfinite(got.rate_hz):
        rate.ok, rate.note = False, "too few reads brought frames to measure the rate"
    elif abs(got.rate_hz / nominal - 1) > RATE_TOLERANCE:
        rate.ok = False
        rate.note = (
            f"{got.rate_hz:.0f} frames/s, the rig file says {nominal:g} "
            f"(daq.sample_rate_hz{scale}; time in recordings would be off by "
            f"{got.rate_hz / nominal:.3g}x)"
        )
    lost = got.dropped + got.corrupt
    share = lost / max(1, lost + got.frames)
    bad = Finding(
        "lost frames",
        f"{got.dropped} dropped, {got.corrupt} damaged ({got.rejected} implausible), "
        f"{got.garbage_bytes} garbage bytes",
    )
    if share > cfg.max_frame_loss:
        bad.ok = False
        bad.note = f"{share:.1%} of frames lost (daq.max_frame_loss {cfg.max_frame_loss:.1%})"
    return [Finding("frames", f"{got.frames} valid in {got.seconds:g} s"), rate, bad]


def _load_cell(s: SampleBlock, lim: Limits) -> Finding:
    force = Finding(
        "load cell",
        f"{np.mean(s.force_n):+.1f} N (sd {np.std(s.force_n):.2f} N, "
        f"{np.min(s.force_n):+.1f}..{np.max(s.force_n):+.1f} N)",
    )
    if _share(s.status, STATUS_LOAD_OVERRANGE):
        force.ok, force.note = False, "over-range bit set: the load cell is saturated"
    elif np.max(np.abs(s.force_n)) > lim.force_n:
        force.ok = False
        force.note = (
            f"reads {np.max(np.abs(s.force_n)):.0f} N at rest, beyond limits.force_n "
            f"{lim.force_n:g} N: a sweep would trip at once (calibration? tare?)"
        )
    return force


def _lvdt(s: SampleBlock, rig: RigConfig, drive_position_m: float | None) -> list[Finding]:
    """The LVDT at rest, and against the drive's own position when it has one."""
    lim = rig.limits
    x = s.displacement_m
    lvdt = Finding("LVDT", f"{_mm(float(np.mean(x)))} from centre (sd {np.std(x) * 1e3:.3f} mm)")
    if _share(s.status, STATUS_LVDT_OVERRANGE):
        lvdt.ok, lvdt.note = False, "over-range bit set: the LVDT is saturated"
    elif np.max(np.abs(x)) > lim.travel_m:
        lvdt.ok = False
        lvdt.note = (
            f"{_mm(float(np.mean(x)))} from centre is outside the travel "
            f"±{lim.travel_m * 1e3:g} mm (daq.calibration.position_*, rig.stroke_centre_m)"
        )
    elif np.std(x) > AT_REST_SD_M:
        lvdt.ok = False
        lvdt.note = f"varies by {np.std(x) * 1e3:.3f} mm sd with the drive at rest: noise or motion"
    if drive_position_m is None:
        return [lvdt]
    gap = float(np.mean(x)) + rig.stroke_centre_m - drive_position_m
    agree = Finding("LVDT vs drive position", f"differ by {gap * 1e3:.2f} mm")
    if abs(gap) > POSITION_AGREEMENT_M:
        agree.ok = False
        agree.note = (
            f"the LVDT and the drive differ by {gap * 1e3:+.2f} mm "
            "(daq.calibration.position_offset_m / position_m_per_count, or the register scale)"
        )
    return [lvdt, agree]


def _temperature(s: SampleBlock, cfg: DaqConfig, lim: Limits) -> Finding:
    t = s.temperature_c
    temp = Finding("temperature", f"{np.mean(t):.1f} °C")
    lo, hi = cfg.temperature_range_c
    if _share(s.status, STATUS_TEMP_FAULT):
        temp.ok, temp.note = False, "sensor fault bit set (thermocouple open?)"
    elif not lo <= float(np.mean(t)) <= hi:
        temp.ok, temp.note = False, f"outside the sensor's range {lo:g}..{hi:g} °C"
    elif float(np.max(t)) > lim.temperature_c:
        temp.ok = False
        temp.note = f"{np.max(t):.1f} °C is above limits.temperature_c: a sweep would stop"
    return temp


def _motion_input(s: SampleBlock) -> Finding:
    motion = _share(s.status, STATUS_MOTION)
    m = Finding("motion input (status bit 0)", f"set in {motion:.0%} of frames")
    if motion:
        m.ok = False
        m.note = "set with no sine running: the drive's motion output is miswired or inverted"
    return m


def check_rig(rig: RigConfig, seconds: float = 1.0) -> CheckResult:
    """Connect, read the drive's registers and `seconds` of DAQ frames; nothing is written."""
    act, daq = open_links(rig)
    result = CheckResult(rig.name, rig.source)
    try:
        result.drive.append(Finding("drive", f"reachable at {rig.actuator.describe()}"))
        regs, pos = check_registers(act, rig)
        result.drive.extend(regs)
        result.daq = check_daq(listen(daq, seconds), rig, pos)
    finally:
        with contextlib.suppress(Exception):
            act.close()
        daq.close()
    return result
