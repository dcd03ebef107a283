"""Contract checks that need the simulated rig's known truth or its fault injection."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from contract_helpers import Collector, drive_status, settled_status

from shockdyno.errors import RigFault
from shockdyno.rig.actuator import ModbusActuator
from shockdyno.rig.frames import FrameDecoder
from shockdyno.run.session import RigSession
from shockdyno.simrig import Fault

CENTRE_MM = 1.0


@pytest.mark.parametrize(
    ("fault", "kind", "reason", "code"),
    [
        (Fault("over_force", force_n=9000.0, duration_s=0.3), "force", "force limit", None),
        (Fault("actuator_fault"), "actuator_fault", "actuator fault: drive fault", 0),
        (Fault("freeze"), "daq_frozen", "DAQ frozen", None),
        (Fault("modbus_timeout"), "link_lost", "failed", 1),
        (Fault("daq_disconnect"), "link_lost", "link lost", 0),
        (Fault("drop", count=120), "daq_gap", "DAQ gap: 120 frames lost in a row", 0),
    ],
    ids=lambda v: v.kind if isinstance(v, Fault) else None,
)
def test_every_fault_ends_in_a_controlled_stop_centred_and_disabled(
    leak_check: None,
    sim_rig_factory,
    fault: Fault,
    kind: str,
    reason: str,
    code: int | None,
) -> None:
    sim = sim_rig_factory(speed=10.0)
    rig = sim.rig_config()
    injected: list[float] = []

    def inject_mid_run(block) -> None:
        if not injected and len(block) and block.t_s[-1] > t_go:
            injected.append(float(block.t_s[-1]))
            sim.inject(fault)

    with RigSession(rig) as session:
        t_go = session.daq_time_s + 1.5
        out = session.run_sine(0.03, 1.5, 1, 6, inject_mid_run)
    assert injected and out.status == "aborted"
    assert reason in out.reason
    assert kind in [e.kind for e in out.events]
    if fault.kind == "modbus_timeout":
        sim.inject(Fault("modbus_timeout", duration_s=0.01))  # let the test read the drive again
        time.sleep(0.1)
        sim.call(lambda: setattr(sim, "_mute_until", -1.0))
    st = settled_status(rig)
    assert not st.enabled and not st.running
    assert abs(st.position_m - rig.stroke_centre_m) * 1e3 < CENTRE_MM
    if code is not None:  # the host resets a drive fault it can reach; a lost link cannot
        assert st.fault_code == code
    assert [e.kind for e in session.events][-1] == "closed"


def test_corrupted_and_dropped_frames_are_counted_and_never_delivered(
    sim_rig_factory,
) -> None:
    sim = sim_rig_factory(speed=20.0)
    rec = Collector()

    faults = [(0.3, Fault("garble", count=25)), (1.3, Fault("drop", count=6))]

    def collect(block) -> None:
        rec.block(block)
        # s into the motion, apart: one gap holding both is split by an estimate
        if faults and rec.moved_for(faults[0][0]):
            sim.inject(faults.pop(0)[1])

    with RigSession(sim.rig_config()) as session:
        out = session.run_sine(0.03, 1.5, 1, 3, collect)
    assert out.status == "complete"
    assert (out.corrupt_frames, out.dropped_frames) == (25, 6)
    b = rec.all
    gaps = np.diff(b.seq)
    assert np.all(gaps >= 1) and int((gaps - 1).sum()) == 31
    # A delivered sample is the plant's smooth motion, never a flipped byte.
    step = np.diff(b.displacement_m) / gaps  # per sample, across gaps too
    assert np.max(np.abs(step)) < 0.3e-3  # 0.28 m/s peak at 1 kHz
    assert np.max(np.abs(b.force_n)) < 3000


def test_heartbeat_loss_makes_the_drive_stop_by_itself(sim_rig_factory) -> None:
    sim = sim_rig_factory(speed=5.0)
    rig = sim.rig_config()
    act = ModbusActuator(rig)
    act.connect()
    try:
        act.write({"heartbeat_timeout_ms": 300, "move_velocity": 0.05})
        act.control("fault_reset", enable=True)
        act.write({"position_command": rig.stroke_centre_m})
        for _ in range(20):  # beat while it centres
            act.beat()
            time.sleep(0.02)
        act.set_mode("sine")
        act.write(
            {
                "sine_amplitude": 0.02,
                "sine_frequency": 1.0,
                "sine_centre": rig.stroke_centre_m,
                "sine_cycles": 50,
                "sine_ramp_cycles": 1,
            }
        )
        act.control("start")
        assert act.status().running
        time.sleep(1.0)  # no heartbeat from here on
        st = act.status()
        assert st.fault_code == 1 and st.fault_text == "heartbeat lost"
        assert not st.enabled and not st.running
        assert abs(st.position_m - rig.stroke_centre_m) < CENTRE_MM * 1e-3
        assert st.cycle_count is not None and st.cycle_count < 10
    finally:
        act.close()


def test_motorised_clicks_change_the_force_as_the_model_says(sim_rig_factory) -> None:
    sim = sim_rig_factory(speed=20.0)
    peaks = {}
    with RigSession(sim.rig_config()) as session:
        for clicks in (2, 20):
            session.set_clicks(clicks, 0)
            rec = Collector()
            out = session.run_sine(0.02, 1.5, 1, 2, rec.block)
            assert out.status == "complete"
            peaks[clicks] = float(np.max(rec.all.force_n))
    st = drive_status(sim.rig_config())
    assert not st.enabled
    a2, a20 = sim.true_bleed_areas(2), sim.true_bleed_areas(20)
    assert a20[0] > a2[0]  # more clicks open the bleed...
    assert peaks[20] < 0.8 * peaks[2]  # ...and the damper pushes back less


def _frames(sim, until_seq: int, least: int, deadline_s: float) -> dict[int, int]:
    """seq -> load count of the frames a fresh listener reads: at least `least` of them
    and on until one at or past `until_seq` (or the deadline)."""
    import serial

    port = serial.serial_for_url(sim.rig_config().daq.url, timeout=0.05)
    dec = FrameDecoder()
    out: dict[int, int] = {}
    end = time.monotonic() + deadline_s
    try:
        while (len(out) < least or max(out) < until_seq) and time.monotonic() < end:
            got = dec.feed(port.read(4096))
            out.update(zip(got.seq.tolist(), got.load.tolist(), strict=True))
    finally:
        port.close()
        sim.close()
    return out


def test_same_seed_same_frames_at_any_speed(sim_rig_factory) -> None:
    # The rig streams from its start whether or not anyone listens, so a listener misses
    # the frames sent before it connects: at 25x, 25 per ms of a slow connect on a busy
    # machine. So the fast rig is read first, and the real-time one on until it reaches
    # the fast one's frames.
    fast = _frames(sim_rig_factory(speed=25.0, seed=7), 0, 400, 5.0)
    assert len(fast) >= 400
    first = min(fast)
    slow = _frames(sim_rig_factory(speed=1.0, seed=7), first + 200, 200, 60.0)
    common = sorted(set(fast) & set(slow))
    assert len(common) >= 100, (first, min(slow), max(slow))
    assert [fast[s] for s in common] == [slow[s] for s in common]
    # ...and not merely one constant reading: the frames carry a moving, noisy signal
    assert len({fast[s] for s in common}) > 10


def test_no_thread_socket_or_pty_left_behind(leak_check: None, sim_rig_factory) -> None:
    sim = sim_rig_factory(serial="both", speed=20.0)
    with RigSession(sim.pty_config()) as session:
        session.run_sine(0.01, 2.0, 0, 1, lambda b: None)
    sim.close()


def test_unreachable_rig_is_one_clear_rig_fault(leak_check: None, sim_rig_factory) -> None:
    sim = sim_rig_factory(speed=20.0)
    rig = sim.rig_config()
    sim.close()
    with pytest.raises(RigFault, match=r"modbus tcp://127.0.0.1:\d+: cannot connect"):
        RigSession(rig).__enter__()
    assert math.isfinite(rig.stroke_centre_m)


def test_ten_minutes_of_rig_time_at_1khz_without_a_lost_frame(sim_rig_factory) -> None:
    """The issue's bar: 30 mm, 1.5 Hz, 10 min of rig time, zero dropped frames."""
    sim = sim_rig_factory(speed=200.0)
    state = {"n": 0, "last": None, "gaps": 0, "amp": 0.0}

    def check(block) -> None:
        seq = block.seq
        if state["last"] is not None:
            state["gaps"] += int(seq[0] - state["last"] - 1)
        state["gaps"] += int((np.diff(seq) - 1).sum())
        state["last"] = int(seq[-1])
        state["n"] += len(block)
        state["amp"] = max(state["amp"], float(np.max(np.abs(block.displacement_m))))

    cycles = 900  # 600 s at 1.5 Hz
    with RigSession(sim.rig_config()) as session:
        out = session.run_sine(0.03, 1.5, 2, cycles - 4, check)
    assert out.status == "complete", out.reason
    assert out.start_s is not None and out.end_s - out.start_s >= 600.0
    assert (out.dropped_frames, out.corrupt_frames, state["gaps"]) == (0, 0, 0)
    assert state["n"] >= 600_000
    assert state["amp"] == pytest.approx(0.03, rel=0.01)


def test_oil_over_temperature_stops_the_test(sim_rig_factory, tmp_path) -> None:
    """The thermal scenario heats the oil past the rig's 90 °C limit mid-run."""
    hot = tmp_path / "hot.toml"
    hot.write_text(
        '[scenario]\nname = "hot"\ndescription = "starts 0.3 K below the limit"\n'
        '[[term]]\nkind = "thermal"\nreference_c = 89.7\n'
        "heat_rate_k_s_m2 = 100.0\ncooling_time_s = 200.0\n"
    )
    sim = sim_rig_factory(scenario=hot, speed=10.0)
    with RigSession(sim.rig_config()) as session:
        assert session.read_temperature_c() < 90.0
        out = session.run_sine(0.03, 1.5, 1, 20, lambda b: None)
    assert out.status == "aborted" and out.reason.startswith("temperature limit")
    st = settled_status(sim.rig_config())
    assert not st.enabled and abs(st.position_m - sim.rig.stroke_centre_m) < 1e-3


def test_the_session_runs_on_any_daq_and_is_an_adjuster(sim_rig_factory) -> None:
    """RigSession depends on the `Daq` protocol, not on SerialDaq: a DAQ that wraps the
    serial one (a logger, a second channel set) runs a whole test; and the session is the
    `Adjuster` the sweep runner sets clicks through."""
    from shockdyno.rig import Adjuster, Daq
    from shockdyno.rig.config import DaqConfig
    from shockdyno.rig.daq import SerialDaq
    from shockdyno.rig.types import SampleBlock

    class CountingDaq:
        def __init__(self, config: DaqConfig, centre_m: float) -> None:
            self.inner = SerialDaq(config, centre_m)
            self.sample_rate_hz = self.inner.sample_rate_hz
            self.samples = 0

        def read(self) -> SampleBlock:
            block = self.inner.read()
            self.samples += block.t_s.size
            return block

        @property
        def dropped_frames(self) -> int:
            return self.inner.dropped_frames

        @property
        def corrupt_frames(self) -> int:
            return self.inner.corrupt_frames

        def close(self) -> None:
            self.inner.close()

    sim = sim_rig_factory(speed=20.0)
    opened: list[CountingDaq] = []

    def open_daq(config: DaqConfig, centre_m: float) -> CountingDaq:
        opened.append(CountingDaq(config, centre_m))
        return opened[-1]

    with RigSession(sim.rig_config(), open_daq=open_daq) as session:
        assert isinstance(session, Adjuster) and isinstance(opened[0], Daq)
        assert isinstance(opened[0].inner, Daq)
        session.set_clicks(10, 0)
        rec = Collector()
        out = session.run_sine(0.02, 1.5, 1, 2, rec.block)
    assert out.status == "complete"
    assert opened[0].samples >= rec.all.t_s.size > 1000  # every sample came through it
