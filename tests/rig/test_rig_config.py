"""Rig files: every shipped file loads; mistakes are one-line ConfigErrors naming file and key."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from shockdyno.errors import ConfigError
from shockdyno.rig.config import Register, load_rig, parse_rig
from shockdyno.rig.daq import calibrate
from shockdyno.rig.frames import RawFrames
from shockdyno.rig.registers import decode, encode

REPO = Path(__file__).resolve().parents[2]
SIM_TEXT = (REPO / "rigs" / "sim.toml").read_text()
W = 'word_order = "big"'  # a place to add register-map keys


@pytest.mark.parametrize("path", sorted((REPO / "rigs").glob("*.toml")), ids=lambda p: p.name)
def test_every_shipped_rig_file_loads(path: Path) -> None:
    rig = load_rig(path)
    assert rig.raw_toml == path.read_text()
    assert rig.limits.travel_m > 0 and rig.sample_rate_hz > 0


def test_the_three_transports_are_represented() -> None:
    kinds = {load_rig(p).actuator.kind for p in (REPO / "rigs").glob("*.toml")}
    assert kinds == {"tcp", "rtu"}
    hw = load_rig(REPO / "rigs" / "example-servo-hydraulic.toml")
    assert hw.daq.url == "/dev/ttyUSB0" and hw.registers.word_order == "little"
    assert hw.registers["position_actual"].scale == pytest.approx(1e-6)
    assert hw.registers.fault_text(7) == "hydraulic pressure low"


@pytest.mark.parametrize(
    ("old", "new", "fragment"),
    [
        ("travel_m = 0.045", "travel_m = -1", "limits.travel_m: must be a number > 0, got -1"),
        ("travel_m = 0.045", "travel_m = inf", "limits.travel_m: must be a finite number"),
        ("[rig]", "[rig]\nnme = 1", "rig.nme: unknown key (did you mean name?)"),
        ('transport = "tcp"', 'transport = "tcp"\nbaudrate = 9600', "not used with transport"),
        ("[daq]", "[daq]\nforce_range_n = [5, 1]", "daq.force_range_n: must be [LOW, HIGH]"),
        ("[daq]", "[daq]\nforce_range_n = [5]", "daq.force_range_n: must be a list [a number"),
        ("sine_ramp_cycles = 1", "sine_ramp_cycles = 2.5", "must be a whole number from 1 to 100"),
        ('transport = "tcp"', 'transport = ["tcp"]', "actuator.transport: must be one of tcp, rtu"),
        (
            W,
            W + '\nforce_actul = { address = 40, type = "int32" }',
            "registers.force_actul: unknown register (did you mean force_actual?)",
        ),
        (W, W + '\nfault_codes = { "²" = "x" }', 'fault_codes."²": fault codes are whole numbers'),
        (W, W + '\nfault_codes = { 70000 = "x" }', "fault_codes.70000: fault codes are whole"),
        (W, W + '\nfault_codes = { 7 = "a", "07" = "b" }', "fault_codes.07: fault code 7 given"),
        (W, W + '\nfault_codes = { 7 = "" }', "fault_codes.7: must be non-empty text in quotes"),
        (W, W + "\ncontrol_bits = { enabel = 0 }", "enabel: unknown name (did you mean enable?)"),
        (W, W + "\ncontrol_bits = { enable = 1 }", "control_bits.enable: 1 is start's too"),
        ("[rig]", '[rig]\n"a.b" = 1', 'rig."a.b": unknown key'),
        ("[rig]", '[rig]\n"x\\ny" = 1', 'rig."x\\ny": unknown key'),
        ("travel_m = 0.045", 'travel_m = "far"', "limits.travel_m: must be a number"),
        ("sample_rate_hz = 1000.0\n", "", "daq.sample_rate_hz: missing"),
        ('transport = "tcp"', 'transport = "udp"', "actuator.transport: must be one of"),
        (
            'mode = { address = 2, type = "uint16" }',
            'mode = { address = 1, type = "uint16" }',
            "overlaps register",
        ),
        (
            'cycle_count = { address = 28, type = "int32"',
            'cycle_count = { address = 28, type = "int64"',
            "type: must be one of",
        ),
        ("[ramp]", "[ramp]\nspeed = 3", "ramp.speed: unknown key"),
        ('adjuster = "motorised"', 'adjuster = "robot"', "rig.adjuster: must be one of"),
        (
            "period_s = 0.1\ntimeout_s = 1.0",
            "period_s = 0.1\ntimeout_s = 0.1",
            "heartbeat.timeout_s: must be at least twice",
        ),
        ('url = "socket://127.0.0.1:5021"', 'url = "/dev/ttyUSB0"\nbaudrate_x = 1', "unknown key"),
        (
            'position_actual = { address = 12, type = "float32", writable = false }\n',
            "",
            "position_actual: missing register",
        ),
        (  # bool("false") is True: a quoted false made the register writable
            'type = "uint16", writable = false }',
            'type = "uint16", writable = "false" }',
            "writable: must be true or false",
        ),
    ],
)
def test_mistakes_name_file_and_key(old: str, new: str, fragment: str) -> None:
    assert old in SIM_TEXT
    with pytest.raises(ConfigError) as info:
        parse_rig(SIM_TEXT.replace(old, new, 1), "rigs/bad.toml")
    msg = str(info.value)
    assert msg.startswith("rigs/bad.toml") and fragment in msg and "\n" not in msg


def test_baud_rate_too_slow_for_the_frame_rate() -> None:
    text = SIM_TEXT.replace(
        'url = "socket://127.0.0.1:5021"\nbaudrate = 921600',
        'url = "/dev/ttyUSB0"\nbaudrate = 115200',
    )
    with pytest.raises(ConfigError, match=r"daq.baudrate: 115200 baud cannot carry 1000 frames/s"):
        parse_rig(text, "x.toml")


def test_missing_and_garbled_files() -> None:
    with pytest.raises(ConfigError, match=r"rig file not found: nowhere\.toml"):
        load_rig("nowhere.toml")
    with pytest.raises(ConfigError, match="not valid TOML"):
        parse_rig("[rig\nname=", "bad.toml")


@pytest.mark.parametrize(
    ("reg", "value", "order", "words"),
    [
        (Register("f", 0, "float32"), 1.0, "big", [0x3F80, 0x0000]),
        (Register("f", 0, "float32"), 1.0, "little", [0x0000, 0x3F80]),
        (Register("i", 0, "int32", scale=1e-6), 0.075, "big", [0x0001, 0x24F8]),  # 75000 µm
        (Register("i", 0, "int32"), -1, "big", [0xFFFF, 0xFFFF]),
        (Register("u", 0, "uint16"), 500, "big", [500]),
    ],
)
def test_register_words(reg: Register, value: float, order: str, words: list[int]) -> None:
    assert encode(reg, value, order) == words
    assert decode(reg, words, order) == pytest.approx(value)


def test_register_range_is_checked() -> None:
    with pytest.raises(ConfigError, match="does not fit a uint16"):
        encode(Register("u", 0, "uint16"), 70000)


def test_calibration_counts_to_si_relative_to_centre() -> None:
    rig = load_rig(REPO / "rigs" / "sim.toml")
    raw = RawFrames(
        np.array([1000, 1001]),
        np.array([2000, -2000], np.int32),
        np.array([75000, 105000], np.int32),
        np.array([4000, 4010], np.int16),
        np.array([0, 1], np.uint16),
    )
    b = calibrate(raw, rig.daq.calibration, 1000.0, rig.stroke_centre_m)
    assert np.allclose(b.t_s, [1.0, 1.001])
    assert np.allclose(b.force_n, [100.0, -100.0])  # 0.05 N/count
    assert np.allclose(b.displacement_m, [0.0, 0.030])  # 1 µm/count, centre 75 mm
    assert np.allclose(b.temperature_c, [40.0, 40.1])


@pytest.mark.parametrize(
    ("old", "new", "fragment"),
    [
        ("travel_m = 0.045", "travel_m = 10", "limits.travel_m: must be at most 0.5 m"),
        ("force_n = 6000.0", "force_n = 1e9", "limits.force_n: must be at most 200000 N"),
        ("velocity_m_s = 0.6", "velocity_m_s = 100", "limits.velocity_m_s: must be at most 15"),
        ("temperature_c = 90.0", "temperature_c = 250", "limits.temperature_c: must be at most"),
        ("move_velocity_m_s = 0.02", "move_velocity_m_s = 0.9", "exceeds limits.velocity_m_s"),
        ("timeout_s = 1.0\n", "timeout_s = 60\n", "heartbeat.timeout_s: must be at most 5 s"),
        ("[daq]", "[daq]\nposition_range_m = [0.0, 0.1]", "trips at [0.02775, 0.12225]"),
        ("[daq]", "[daq]\nforce_range_n = [-5000, 5000]", "outside the sensor's daq.force_range_n"),
        ("[daq]", "[daq]\ntemperature_range_c = [-40, 80]", "limits.temperature_c: trips at"),
    ],
)  # fmt: skip
def test_absurd_limits_and_limits_no_sensor_can_see_are_refused(
    old: str, new: str, fragment: str
) -> None:
    """Issue 46.2: travel 10 m, 1e9 N and 100 m/s were accepted, and only the simulated
    drive refused what followed."""
    assert old in SIM_TEXT
    with pytest.raises(ConfigError, match=r"^rig\.toml: ") as exc:
        parse_rig(SIM_TEXT.replace(old, new, 1), "rig.toml")
    assert fragment in str(exc.value) and "\n" not in str(exc.value)
