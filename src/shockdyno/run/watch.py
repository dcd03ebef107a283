"""What the session commanded and the drive must keep.

Setpoints the host wrote are read back on every poll, and the drive's state too: another
Modbus master (or the drive's own panel) changing a setpoint, disabling the drive while
the session holds it enabled, or stopping a sine before its end is a controlled stop,
never a test that silently runs something else.
"""

from __future__ import annotations

import math

from shockdyno.rig.actuator import ActuatorStatus
from shockdyno.run.safety import SafetyEvent, SafetyTrip


class DriveWatch:
    """The setpoints this session wrote and the running state a sine must keep, checked at every
    status poll: a difference is a trip."""

    def __init__(self) -> None:
        self.setpoints: dict[str, float] = {}  # register -> the value this session wrote
        # DAQ time until which a running sine must keep the drive's running bit, and the
        # cycles (ramps included) the drive must count; None: no sine running.
        self.running_until: float | None = None
        self.running_cycles = 0.0

    def expect(self, values: dict[str, float]) -> None:
        """Note setpoints the host wrote (register → engineering value), to be read back at every
        poll."""
        self.setpoints.update(values)

    def sine_running(self, until: float | None, cycles: float = 0.0) -> None:
        """Note that a sine must keep the drive running until DAQ time `until` (s; None: no sine)
        and count `cycles`."""
        self.running_until = until
        self.running_cycles = cycles

    def check_setpoints(self, got: dict[str, float], when: str, t: float) -> None:
        """A setpoint the drive holds that differs from what the host wrote is a trip."""
        for name, value in got.items():
            want = self.setpoints.get(name)
            if want is not None and not math.isclose(value, want, rel_tol=1e-6, abs_tol=1e-9):
                raise SafetyTrip(
                    SafetyEvent(
                        t,
                        "setpoint_changed",
                        f"{name} reads {value:g} {when}, commanded {want:g}: "
                        "another Modbus master wrote to the drive",
                    )
                )

    def check_state(self, st: ActuatorStatus, t: float, armed: bool, fresh: bool) -> None:
        """The drive's state read back like its setpoints: disabled while the session holds
        it enabled (`armed`), or stopped while a sine should run, is a change the session
        did not make and a controlled stop. `t`: the DAQ time; `fresh`: whether the DAQ's
        latest read brought samples (its clock is current)."""
        if armed and not st.enabled and not st.fault:
            raise SafetyTrip(
                SafetyEvent(
                    t,
                    "drive_disabled",
                    f"the drive reports disabled (status word 0x{st.word:04x}) while this "
                    "session held it enabled: another Modbus master or the drive's panel "
                    "disabled it",
                )
            )
        until = self.running_until
        if until is None or st.running or st.fault:
            return
        if st.cycle_count is not None:
            # The drive's own count: a sine that ended as planned counted every cycle,
            # whatever the DAQ stream (which lags the drive at a fast sim's speed) shows.
            early = st.cycle_count < math.floor(self.running_cycles + 1e-9)
            said = f"after {st.cycle_count} of {self.running_cycles:g} cycles"
        else:
            # Judged on the DAQ clock, so only while it is current: a frozen DAQ's last
            # sample is older than the drive, which may have ended as planned meanwhile.
            early = fresh and t < until
            said = f"{until - t:.3g} s before its end"
        if not early:
            return
        raise SafetyTrip(
            SafetyEvent(
                t,
                "drive_stopped",
                f"the drive stopped the sine {said} (status word 0x{st.word:04x}): another "
                "Modbus master or the drive's panel stopped it",
            )
        )
