"""Helpers shared by the contract suites."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from shockdyno.rig.actuator import ActuatorStatus, ModbusActuator
from shockdyno.rig.config import RigConfig
from shockdyno.rig.frames import STATUS_MOTION
from shockdyno.samples import SampleBlock


@dataclass
class Backend:
    name: str
    rig: RigConfig
    sim: Any | None  # the SimRig, when simulated


class Collector:
    def __init__(self) -> None:
        self.blocks: list[SampleBlock] = []
        self.actuator: list[tuple[float, dict[str, Any]]] = []
        self.motion_start_s: float | None = None  # DAQ time the motion output rose

    def block(self, b: SampleBlock) -> None:
        self.blocks.append(b)
        moving = np.flatnonzero(b.status & STATUS_MOTION)
        if self.motion_start_s is None and moving.size:
            self.motion_start_s = float(b.t_s[moving[0]])

    def moved_for(self, seconds: float) -> bool:
        """Whether the sine has run `seconds` of DAQ time: a trigger that does not depend on
        how many samples each read brings (a loaded host reads fewer, larger blocks)."""
        start = self.motion_start_s
        return start is not None and float(self.blocks[-1].t_s[-1]) >= start + seconds

    def act(self, t: float, fields: dict[str, Any]) -> None:
        self.actuator.append((t, fields))

    @property
    def all(self) -> SampleBlock:
        return SampleBlock.concat(self.blocks)


def drive_status(rig: RigConfig) -> ActuatorStatus:
    """The drive's state as a fresh client sees it (after the session has gone)."""
    act = ModbusActuator(rig)
    act.connect()
    try:
        return act.status()
    finally:
        act.close()


def settled_status(rig: RigConfig, timeout_s: float = 5.0) -> ActuatorStatus:
    """Status once the drive has finished whatever stop it was making."""
    end = time.monotonic() + timeout_s
    st = drive_status(rig)
    while (st.running or st.enabled) and time.monotonic() < end:
        time.sleep(0.05)
        st = drive_status(rig)
    return st


def sine_fit(b: SampleBlock, f: float, t0: float, t1: float) -> tuple[float, float]:
    """Amplitude and offset of the f-Hz sine in [t0, t1)."""
    m = (b.t_s >= t0) & (b.t_s < t1)
    t, x = b.t_s[m], b.displacement_m[m]
    w = 2 * np.pi * f
    basis = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    (s, c, off), *_ = np.linalg.lstsq(basis, x, rcond=None)
    return float(np.hypot(s, c)), float(off)


def motion_start(b: SampleBlock) -> float:
    return float(b.t_s[np.argmax((b.status & STATUS_MOTION) != 0)])
