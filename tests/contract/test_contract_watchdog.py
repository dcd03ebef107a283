"""The drive's watchdog is a proof of life of the control loop (issue 46.1): a main thread
that blocks leaves the drive to stop itself, and a wait on a person is made with the drive
disabled. Seen by a second Modbus client, not taken from the session."""

from __future__ import annotations

import time
from dataclasses import replace

import pytest
from contract_helpers import Collector, settled_status

from shockdyno.errors import RigFault
from shockdyno.rig.actuator import ActuatorStatus, ModbusActuator
from shockdyno.run.session import RigSession
from shockdyno.simrig.drive import HEARTBEAT_LOST


def _client(rig) -> ModbusActuator:  # type: ignore[no-untyped-def]
    act = ModbusActuator(rig)
    act.connect()
    return act


def test_a_blocked_control_loop_lets_the_drive_stop_itself(sim_rig_factory) -> None:
    """Nothing beats while the loop is stuck (here: its sample sink blocks for longer than
    the watchdog): the drive trips 'heartbeat lost' mid-sine on its own, and the session,
    once it runs again, sees the fault and stops, centres and disables."""
    sim = sim_rig_factory(speed=4.0)
    rig = sim.rig_config()
    watchdog_s = rig.heartbeat.timeout_s
    probe = _client(rig)
    rec = Collector()
    seen: list[ActuatorStatus] = []

    def stuck(block) -> None:  # type: ignore[no-untyped-def]
        rec.block(block)
        if not seen and rec.moved_for(1.0):
            t0 = time.monotonic()
            while time.monotonic() - t0 < watchdog_s + 1.5:  # the main thread is stuck
                st = probe.status()
                seen.append(st)
                if st.fault and not st.running and not st.enabled:
                    break
                time.sleep(0.02)

    try:
        with RigSession(rig) as session:
            out = session.run_sine(0.02, 1.0, 1, 4, stuck)
    finally:
        probe.close()
    assert seen and seen[0].running  # the sine was running when the loop stopped
    stopped = [s for s in seen if s.fault_code == HEARTBEAT_LOST]
    assert stopped, [s.fault_text for s in seen]  # the drive's own watchdog acted
    assert not seen[-1].enabled and not seen[-1].running
    assert out.status == "aborted" and "heartbeat lost" in out.reason
    st = settled_status(rig)
    assert not st.enabled and not st.running and not st.fault
    assert st.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)


def test_a_signal_during_a_stall_past_the_watchdog_still_centres(sim_rig_factory) -> None:
    """A loaded host stalls the sweep process past the watchdog mid-sine (the drive trips,
    ramps the sine out and then disables itself), and a SIGTERM arrives meanwhile: the
    teardown's stop, reset and centring ran while the drive's own disable was still to
    come, which cut the move to the centre short (a CI run: 64.9 mm against a 75 mm
    centre). The teardown waits for the watchdog's disable before it resets and centres.
    Whether the old order lost the race depends on timing: this test passed without the
    fix on an idle machine; it holds the sequence, the CI run found the race."""
    sim = sim_rig_factory(speed=4.0)
    rig = sim.rig_config()
    probe = _client(rig)
    rec = Collector()
    tripped: list[ActuatorStatus] = []

    def stalled(block) -> None:  # type: ignore[no-untyped-def]
        rec.block(block)
        if rec.moved_for(0.6):  # off centre: about a quarter of a 0.5 Hz cycle in
            t0 = time.monotonic()
            while time.monotonic() - t0 < rig.heartbeat.timeout_s + 2.0:
                st = probe.status()
                if st.fault:  # tripped; still ramping the sine out
                    tripped.append(st)
                    break
                time.sleep(0.02)
            raise KeyboardInterrupt  # the signal: its stop re-ramps what the trip began

    try:
        with pytest.raises(KeyboardInterrupt), RigSession(rig) as session:
            session.run_sine(0.02, 0.5, 1, 4, stalled)
        final = settled_status(rig)
    finally:
        probe.close()
    assert tripped and tripped[0].fault_code == HEARTBEAT_LOST
    assert not final.enabled and not final.running and not final.fault
    assert final.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)
    kinds = [e.kind for e in session.events]
    assert "stop_step_failed" not in kinds
    i = kinds.index("reset")
    assert kinds[i : i + 3] == ["reset", "centre", "disable"]


def test_a_drive_disabled_by_another_master_is_not_enabled_to_centre(sim_rig_factory) -> None:
    """Re-enabling is for the session's own watchdog lapse only: a drive another master
    (a panel, an emergency stop) disabled mid-sine stays disabled where it is."""
    sim = sim_rig_factory(speed=4.0)
    rig = sim.rig_config()
    intruder = _client(rig)
    rec = Collector()

    def panel(block) -> None:  # type: ignore[no-untyped-def]
        rec.block(block)
        if rec.moved_for(0.6) and intruder.status().enabled:
            intruder.control(enable=False)

    try:
        with RigSession(rig) as session:
            out = session.run_sine(0.02, 0.5, 1, 4, panel)
        final = settled_status(rig)
    finally:
        intruder.close()
    assert out.status == "aborted"
    assert not final.enabled and abs(final.position_m - rig.stroke_centre_m) > 2e-3
    assert "reset" not in [e.kind for e in session.events]  # no fault: nothing re-enabled it


def test_the_drive_is_disabled_while_the_operator_sets_the_clicks(sim_rig_factory) -> None:
    """An operator rig's prompt waits on a person: the drive is off meanwhile, so another
    master's +49 mm command moves nothing, and the session enables and centres again after
    the answer."""
    sim = sim_rig_factory(speed=10.0)
    rig = replace(sim.rig_config(), adjuster="operator")
    intruder = _client(rig)
    during: list[ActuatorStatus] = []

    def prompt(message: str) -> None:
        during.append(intruder.status())
        intruder.write({"position_command": rig.stroke_centre_m + 0.049})
        time.sleep(rig.heartbeat.timeout_s + 0.5)  # the operator takes a while
        during.append(intruder.status())

    try:
        with RigSession(rig, prompt=prompt) as session:
            session.set_clicks(7, 0)
            after = intruder.status()
    finally:
        intruder.close()
    assert [s.enabled for s in during] == [False, False]
    assert during[1].position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)  # not moved
    assert after.enabled and after.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)
    kinds = [e.kind for e in session.events]
    i = kinds.index("adjust")
    assert kinds[i - 3 : i] == ["disable", "enable", "centre"]  # off for the prompt, on after


def test_a_ram_moved_while_the_drive_was_off_is_not_enabled_again(sim_rig_factory) -> None:
    """Another master enables the drive during the prompt and sends the ram to +49 mm: no
    one feeds the watchdog, so the drive disables itself within its watchdog time (no
    heartbeat thread keeps it alive), and after the answer the session reads the ram beyond
    its travel limit and does not enable it."""
    sim = sim_rig_factory(speed=10.0)
    rig = replace(sim.rig_config(), adjuster="operator")
    intruder = _client(rig)
    watchdog_s = rig.heartbeat.timeout_s
    off_after: list[float] = []

    def prompt(message: str) -> None:
        intruder.write({"move_velocity": 0.5})
        intruder.control("fault_reset", enable=True)
        intruder.write({"position_command": rig.stroke_centre_m + 0.049})
        t0 = time.monotonic()
        while time.monotonic() - t0 < watchdog_s + 3.0:  # a starved simulator runs late
            if not intruder.status().enabled:
                off_after.append(time.monotonic() - t0)
                return
            time.sleep(0.02)

    try:
        with pytest.raises(RigFault, match="travel limit"), RigSession(rig, prompt=prompt) as s:
            s.set_clicks(7, 0)
        final = intruder.status()
    finally:
        intruder.close()
    # Off during the prompt, with only the drive's own watchdog to do it (a heartbeat
    # thread kept it enabled for as long as the prompt waited).
    assert off_after and off_after[0] >= watchdog_s * 0.9, off_after
    assert not final.enabled and final.position_m - rig.stroke_centre_m > 0.045
