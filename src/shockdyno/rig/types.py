"""Shared rig data types and the small device contracts the sweep runner depends on."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol, runtime_checkable

from shockdyno.samples import SampleBlock


@runtime_checkable
class Daq(Protocol):
    """A DAQ: samples (force, displacement, temperature, status) on its own clock at
    `sample_rate_hz`, and counts of what it lost."""

    sample_rate_hz: float

    def read(self) -> SampleBlock:
        """Every complete, valid sample waiting now (possibly none); never blocks long."""
        ...

    @property
    def dropped_frames(self) -> int:
        """Frames the DAQ's sequence numbers show were never received."""

    @property
    def corrupt_frames(self) -> int:
        """Frames refused as damaged."""

    def close(self) -> None:
        """Release the link."""


@runtime_checkable
class Adjuster(Protocol):
    """Sets the damper's adjuster clicks before a test: a motor through the drive's registers, or
    an operator prompted."""

    def set_clicks(self, rod_clicks: int, gas_clicks: int) -> None:
        """Set the damper's adjusters (a motor, or an operator prompt that waits)."""

    def set_adjusters(self, setting: Mapping[str, int], gas_clicks: int) -> None:
        """Set each named adjuster of a damper with several (a register
        `NAME_clicks` each, or a prompt), and the gas bottle."""
        ...
