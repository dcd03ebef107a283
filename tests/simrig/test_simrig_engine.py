"""The simulated rig's engine: deterministic frames, servo tracking, model force, drive trips."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from shockdyno.model import force_from_displacement, load_spec
from shockdyno.rig.config import load_rig
from shockdyno.rig.daq import calibrate
from shockdyno.rig.frames import STATUS_MOTION, FrameDecoder
from shockdyno.simrig.drive import DRIVE_FAULT, OVER_FORCE
from shockdyno.simrig.engine import SimEngine
from shockdyno.simrig.faults import Fault, parse_fault

REPO = Path(__file__).resolve().parents[2]
RIG = load_rig(REPO / "rigs" / "sim.toml")
SPEC = load_spec()
C = RIG.stroke_centre_m


def sine_engine(seed: int = 0, faults: list[Fault] | None = None, **kw: float) -> SimEngine:
    e = SimEngine(RIG, SPEC, seed=seed, faults=faults)
    d = e.drive
    d.enable(0.0)
    d.move(0.0, C, 0.05)
    e.advance(400)  # 10 mm at 50 mm/s, then settle
    d.mode = 1
    d.sine_amplitude_m = kw.get("a", 0.03)
    d.sine_frequency_hz = kw.get("f", 1.5)
    d.sine_centre_m = C
    d.sine_cycles = int(kw.get("n", 4))
    d.sine_ramp_cycles = 1
    d.start(e.now_s)
    assert d.fault_code == 0
    return e


def decode(data: bytes):
    return calibrate(FrameDecoder().feed(data), RIG.daq.calibration, 1000.0, C)


def test_any_batch_split_gives_identical_bytes() -> None:
    one = sine_engine(seed=3).advance(3000)
    e = sine_engine(seed=3)
    split = b"".join(e.advance(k) for k in (10, 490, 1000, 20, 1480))
    assert one == split
    assert sine_engine(seed=4).advance(3000) != one  # the seed drives the noise


def test_sine_tracks_within_tolerance_and_motion_output_brackets_it() -> None:
    e = sine_engine(a=0.03, f=1.5, n=4)
    t_start = e.now_s
    b = decode(e.advance(5000))
    motion = (b.status & STATUS_MOTION) != 0
    assert b.t_s[motion][0] == pytest.approx(t_start)
    assert b.t_s[motion][-1] == pytest.approx(t_start + 6 / 1.5 - 0.001)
    steady = (b.t_s >= t_start + 1 / 1.5) & (b.t_s < t_start + 5 / 1.5)
    x = b.displacement_m[steady]
    t = b.t_s[steady] - t_start
    # fit x = A sin(ωt - φ): amplitude and lag of a 60 Hz, ζ = 0.8 position loop
    w = 2 * np.pi * 1.5
    basis = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    (s, c, off), *_ = np.linalg.lstsq(basis, x, rcond=None)
    assert np.hypot(s, c) == pytest.approx(0.03, rel=0.01)
    lag = -np.arctan2(c, s)
    assert lag == pytest.approx(2 * 0.8 * 1.5 / 60, abs=0.005)  # 2ζ f/fn rad
    assert abs(off) < 1e-4
    assert abs(b.displacement_m[-1]) < 1e-4  # ramped out back to centre


def test_load_cell_reads_the_damper_models_force() -> None:
    e = sine_engine(a=0.03, f=1.5, n=3)
    e.set_clicks(14, 3)
    b = decode(e.advance(4000))
    a_bc, a_bt = SPEC.bleed_areas(14, 3)
    model = force_from_displacement(SPEC, b.t_s, b.displacement_m, a_bc, a_bt)
    inner = slice(50, -50)
    err = b.force_n[inner] - model[inner]
    assert np.sqrt(np.mean(err**2)) < 0.02 * np.ptp(b.force_n)
    assert np.ptp(b.force_n) > 1000  # a real damping loop, not the gas force alone


def test_injected_frame_faults_are_exact() -> None:
    faults = [Fault("garble", 1.0, count=7), Fault("drop", 2.0, count=4)]
    e = sine_engine(faults=faults)
    dec = FrameDecoder()
    out = dec.feed(e.advance(2500))
    assert (e.frames_garbled, e.frames_dropped) == (7, 4)
    assert (dec.corrupt_frames, dec.dropped_frames) == (7, 4)
    assert len(out) == 2500 - 11


def test_freeze_stops_the_stream() -> None:
    e = sine_engine(faults=[parse_fault("freeze@1.0")])
    data = e.advance(2000)
    assert len(FrameDecoder().feed(data)) == 600  # from t = 0.4 s to the freeze at 1.0 s


def test_over_force_trips_the_drive_and_it_stops() -> None:
    e = sine_engine(faults=[Fault("over_force", 1.0, duration_s=0.4, force_n=20000.0)])
    b = decode(e.advance(3000))
    d = e.drive
    assert d.fault_code == OVER_FORCE
    assert not d.running(e.now_s)
    tripped = b.t_s[np.argmax(np.abs(b.force_n) > RIG.simulation["drive_force_capacity_n"])]
    after = b.t_s > tripped + 0.5  # quick stop: half a cycle (0.33 s), then the servo settles
    assert np.all(np.abs(b.displacement_m[after]) < 0.001)


def test_actuator_fault_makes_a_controlled_stop_not_a_step() -> None:
    e = sine_engine(faults=[Fault("actuator_fault", 2.0)])
    b = decode(e.advance(3000))
    assert e.drive.fault_code == DRIVE_FAULT
    v = np.diff(b.displacement_m) * 1000
    assert np.max(np.abs(v)) < 2 * np.pi * 1.5 * 0.03 * 1.1  # never faster than the sine


def test_a_stop_in_the_same_instant_as_the_start_stops_the_sine() -> None:
    # A Ctrl-C right after the start: the stop reached the drive before its clock moved,
    # where the sine's envelope is still 0, and the stop was ignored: the sine ran on, the
    # host's controlled stop timed out, and the ram was disabled off centre
    # (benchmarks/results/stop-after-second-ctrl-c-2026-11-30.txt).
    e = sine_engine()
    d = e.drive
    d.stop(e.now_s)
    assert not d.running(e.now_s)
    b = decode(e.advance(2000))
    assert np.all(np.abs(b.displacement_m) < 0.001)  # held at the centre it started from


def test_start_refused_off_centre() -> None:
    e = SimEngine(RIG, SPEC)
    d = e.drive
    d.enable(0.0)  # parked 10 mm below centre
    d.mode, d.sine_amplitude_m, d.sine_frequency_hz, d.sine_centre_m = 1, 0.01, 1.0, C
    d.start(0.0)
    assert d.fault_code == 6 and not d.running(0.0)


@pytest.mark.parametrize(
    ("name", "min_change_n"),
    # same seed, same noise: every difference is the scenario's physics (thermal: +0.4 K in 3 s)
    [("aerated-oil", 100.0), ("thermal", 0.2), ("stiction", 20.0), ("sensor-lag", 20.0)],
)
def test_scenarios_change_what_the_load_cell_sees(name: str, min_change_n: float) -> None:
    from shockdyno.simrig.scenario import load_scenario

    sc = load_scenario(name)
    plain = decode(sine_engine(seed=1).advance(3000))
    e = SimEngine(
        RIG, SPEC, seed=1, terms=sc.terms, term_values=sc.values, lvdt_lag_s=sc.lvdt_lag_s
    )
    d = e.drive
    d.enable(0.0)
    d.move(0.0, C, 0.05)
    e.advance(400)
    d.mode, d.sine_amplitude_m, d.sine_frequency_hz, d.sine_centre_m = 1, 0.03, 1.5, C
    d.sine_cycles, d.sine_ramp_cycles = 4, 1
    d.start(e.now_s)
    b = decode(e.advance(3000))
    assert np.max(np.abs(b.force_n - plain.force_n)) > min_change_n
    if name == "thermal":
        assert b.temperature_c[-100:].mean() > plain.temperature_c[-100:].mean() + 0.1


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("ambient_c = -5.0", None),  # a cold test cell is an ambient, not a mistake
        ("servo_dampin = 0.8", r"simulation.servo_dampin: unknown key \(did you mean servo_damp"),
        ('ambient_c = "hot"', r"simulation.ambient_c: must be a number >= -273.15, got 'hot'"),
        ("initial_position_m = 5.0", r"simulation.initial_position_m: 5 m is beyond drive_trav"),
        ("jam_force_n = 10.0", r"simulation.jam_force_n: unknown key \(a fault sets it\)"),
    ],
)
def test_the_simulation_table_is_read_by_its_types(line: str, message: str | None) -> None:
    import re

    from shockdyno.errors import ConfigError
    from shockdyno.rig.config import parse_rig
    from shockdyno.simrig.engine import SimParams

    key = line.split(" =")[0]
    text = re.sub(rf"^{key} = .*\n", "", (REPO / "rigs" / "sim.toml").read_text(), flags=re.M)
    rig = parse_rig(text.replace("[simulation]\n", f"[simulation]\n{line}\n"), "rigs/x.toml")
    if message is None:
        assert SimParams.from_rig(rig).ambient_c == -5.0
        return
    with pytest.raises(ConfigError, match=f"^rigs/x.toml: {message}"):
        SimParams.from_rig(rig)
