"""One contract suite over every backend: the simulated rig over Modbus TCP on loopback with
the DAQ over socket:// and over a pty, and (opt-in, `--rig FILE`) a real rig."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import numpy as np
import pytest
from contract_helpers import Backend, Collector, drive_status, sine_fit

from shockdyno.errors import ConfigError
from shockdyno.rig.config import RigConfig
from shockdyno.run.daq_stream import BlockSink
from shockdyno.run.gas_measure import MAX_HYSTERESIS_N, OFFSET_M, measure_gas_force
from shockdyno.run.session import RigSession

BACKENDS = ["sim-socket", "sim-pty", pytest.param("hardware", marks=pytest.mark.hardware)]


@pytest.fixture(params=BACKENDS)
def backend(request: pytest.FixtureRequest, sim_rig_factory) -> Iterator[Backend]:
    if request.param == "hardware":
        yield Backend("hardware", request.getfixturevalue("hardware_rig"), None)
        return
    if request.param == "sim-pty":
        sim = sim_rig_factory(serial="pty", speed=10.0)
        yield Backend("sim-pty", sim.pty_config(), sim)
    else:
        sim = sim_rig_factory(serial="socket", speed=20.0)
        yield Backend("sim-socket", sim.rig_config(), sim)


def test_enter_enables_and_centres_exit_disables(backend: Backend) -> None:
    rig = backend.rig
    with RigSession(rig) as session:
        st = drive_status(rig)
        assert st.enabled and not st.fault
        assert st.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)
        # The simulated oil sits at 40 °C; a real damper may be at room temperature. Either
        # way a calibrated channel reads a physical value inside the rig's limit.
        assert -20.0 <= session.read_temperature_c() <= rig.limits.temperature_c
    st = drive_status(rig)
    assert not st.enabled and not st.running
    assert st.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)
    kinds = [e.kind for e in session.events]
    assert kinds[:3] == ["connect", "enable", "centre"]
    assert kinds[-2:] == ["disable", "closed"]
    assert any(e.kind == "exit" and e.message == "session ended" for e in session.events)


def test_sine_tracks_within_tolerance_with_no_lost_frames(backend: Backend) -> None:
    rig = backend.rig
    rec = Collector()
    a, f = 0.02, 2.0
    with RigSession(rig) as session:
        out = session.run_sine(a, f, 1, 3, rec.block, rec.act)
    assert out.status == "complete", out.reason
    assert (out.dropped_frames, out.corrupt_frames) == (0, 0)
    b = rec.all
    assert np.all(np.diff(b.seq) == 1)  # every sample, in order, on the DAQ's clock
    assert out.start_s is not None and out.measured_start_s is not None
    assert out.measured_end_s is not None
    assert out.measured_start_s == pytest.approx(out.start_s + 2 / f)  # ramp + warm-up
    assert out.measured_end_s - out.measured_start_s == pytest.approx(3 / f)
    amp, offset = sine_fit(b, f, out.measured_start_s, out.measured_end_s)
    assert amp == pytest.approx(a, rel=0.02)
    assert abs(offset) < 0.5e-3
    assert b.t_s[-1] >= out.start_s + 5 / f  # ramped out before returning
    assert np.max(np.abs(b.displacement_m)) < a * 1.03  # no overshoot beyond the plan
    assert any("cmd_amplitude_m" in fields for _, fields in rec.actuator)
    assert any("status_word" in fields for _, fields in rec.actuator)


def test_amplitude_beyond_travel_is_refused_before_anything_moves(backend: Backend) -> None:
    rig = backend.rig
    rec = Collector()
    with RigSession(rig) as session:
        before = drive_status(rig)
        with pytest.raises(ConfigError, match="exceeds the rig's travel"):
            session.run_sine(rig.limits.travel_m * 1.01, 0.5, 1, 1, rec.block)
        with pytest.raises(ConfigError, match="peak velocity"):
            session.run_sine(0.03, 10.0, 1, 1, rec.block)
        after = drive_status(rig)
    assert rec.blocks == []
    assert not after.running and after.cycle_count == before.cycle_count
    assert after.position_m == pytest.approx(before.position_m, abs=2e-4)


def _interrupted_then_parked(
    rig: RigConfig, frequency_hz: float, warmup: int, measured: int, sink: BlockSink
) -> RigSession:
    """A 20 mm sine that `sink` interrupts (KeyboardInterrupt); the drive as a fresh
    client then sees it: stopped, disabled and centred."""
    with pytest.raises(KeyboardInterrupt), RigSession(rig) as session:
        session.run_sine(0.02, frequency_hz, warmup, measured, sink)
    st = drive_status(rig)
    assert not st.enabled and not st.running
    assert st.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)
    return session


def test_ctrl_c_mid_sine_stops_centres_and_disables(backend: Backend) -> None:
    rig = backend.rig
    seen = [0]

    def interrupt(block) -> None:
        seen[0] += len(block)
        if seen[0] > 600:
            raise KeyboardInterrupt

    session = _interrupted_then_parked(rig, 1.0, 2, 4, interrupt)
    assert any(e.message == "operator interrupt (Ctrl-C)" for e in session.events)
    assert [e.kind for e in session.events][-2:] == ["disable", "closed"]


def test_ctrl_c_in_a_slow_sine_waits_for_its_ramp_out(sim_rig_factory) -> None:
    """A drive ramps a sine out over one period at least: at 0.1 Hz that is 10 s, longer
    than the rig file's stop time. The stop's wait must last that long (it was the stop
    time + 2 s: the drive was disabled mid-ramp, off centre, on a real-time rig)."""
    sim = sim_rig_factory(speed=4.0)
    rig = sim.rig_config()
    rec = Collector()

    def interrupt(block) -> None:  # type: ignore[no-untyped-def]
        rec.block(block)
        if rec.moved_for(2.5):  # in the 10 s ramp-in, the ram 7 mm off centre
            raise KeyboardInterrupt

    session = _interrupted_then_parked(rig, 0.1, 1, 1, interrupt)
    assert "stop_step_failed" not in [e.kind for e in session.events]


def test_operator_adjuster_prompts_and_waits(backend: Backend) -> None:
    rig = replace(backend.rig, adjuster="operator")
    asked: list[str] = []
    with RigSession(rig, prompt=asked.append) as session:
        session.set_clicks(7, 2)
        with pytest.raises(ConfigError):
            session.set_clicks(-1, 0)
    assert asked == ["Set the rod adjuster to 7 clicks and the gas bottle to 2 clicks"]


def test_rtu_driver_runs_a_session(sim_rig_factory) -> None:
    """The Modbus RTU path of the same driver (RTU frames over socket://, real framing)."""
    sim = sim_rig_factory(modbus="rtu", speed=5.0)
    rig = sim.rig_config()
    assert rig.actuator.kind == "rtu" and rig.actuator.serial_port.startswith("socket://")
    rec = Collector()
    with RigSession(rig) as session:
        session.set_clicks(5, 1)
        out = session.run_sine(0.01, 2.0, 0, 1, rec.block)
    assert out.status == "complete", out.reason
    st = drive_status(rig)
    assert not st.enabled and st.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)


def test_gas_force_measurement_holds_still_where_it_says(backend: Backend) -> None:
    """The gas-force step of a sweep on every backend: it moves to ±5 mm and rests at
    mid-stroke, streaming every sample, and both rests read the same force within the
    refusal band (a sim has no friction at rest; a real damper's seals stay well inside)."""
    rig = backend.rig
    rec = Collector()
    with RigSession(rig) as session:
        gas = measure_gas_force(session, rec.block)
        st = drive_status(rig)
        assert st.enabled and st.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)
    b = rec.all
    assert np.all(np.diff(b.seq) == 1)  # the measurement's samples are all there
    assert b.displacement_m.min() == pytest.approx(-OFFSET_M, abs=5e-4)
    assert b.displacement_m.max() == pytest.approx(OFFSET_M, abs=5e-4)
    assert gas.usable and abs(gas.hysteresis_n) < MAX_HYSTERESIS_N
    assert gas.force_n == pytest.approx(np.mean([gas.after_compression_n, gas.after_rebound_n]))
    if backend.sim is not None:  # the simulated damper's force at rest at mid-stroke
        assert gas.force_n == pytest.approx(230.7, abs=1.0)
