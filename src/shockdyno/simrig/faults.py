"""Faults the simulated rig can inject, scheduled in sim time or triggered on demand.

garble          flip one byte in each of `count` frames and add 3 garbage bytes after each
drop            leave out `count` frames (the sequence counter still advances)
freeze          the DAQ hangs: no more frames (the link stays open)
modbus_timeout  the drive stops answering Modbus for `duration_s` (0: for good)
actuator_fault  the drive trips (fault code 5, "drive fault") and makes a controlled stop
over_force      a jam force of `force_n` ramps in over 0.2 s and lasts `duration_s`
"""

from __future__ import annotations

from dataclasses import dataclass

from shockdyno.errors import ConfigError

KINDS = (
    "garble",
    "drop",
    "freeze",
    "modbus_timeout",
    "daq_disconnect",
    "actuator_fault",
    "over_force",
)


@dataclass(frozen=True)
class Fault:
    """One injected fault: its kind (module doc), when (s of sim time), a frame count, a duration
    (s), and the jam force (N) of an over-force."""

    kind: str
    at_s: float = 0.0
    count: int = 1
    duration_s: float = 0.0
    force_n: float = 20000.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ConfigError(f"unknown fault {self.kind!r} (one of {', '.join(KINDS)})")
        if self.at_s < 0 or self.count < 1 or self.duration_s < 0:
            raise ConfigError(f"fault {self.kind}: times and counts must be positive")


def parse_fault(text: str) -> Fault:
    """`kind@seconds[:n]`: n is a frame count (garble, drop) or a duration in s (others)."""
    kind, _, rest = text.partition("@")
    when, _, extra = rest.partition(":")
    try:
        at = float(when) if when else 0.0
        if kind in ("garble", "drop"):
            return Fault(kind, at, count=int(extra) if extra else 1)
        return Fault(kind, at, duration_s=float(extra) if extra else 0.0)
    except ValueError:
        raise ConfigError(f"bad fault {text!r}: expected kind@seconds[:n]") from None
