"""The session's state machine: the drive as this session left it, every transition in
one table, and which of the session's calls each state allows.

    idle, enabled, parked  ──enable──────────────►  enabled
    enabled                ──a motion────────────►  moving  ──it ends──►  enabled
    enabled                ──a wait on a person──►  parked
    enabled, moving, parked, idle  ──a stop (disable)──►  idle
    every state but closed  ──teardown──►  closed (nothing is allowed after it)

`idle`: the drive is not enabled by this session (not yet, or disabled after a stop);
`enabled`: enabled, the watchdog fed, the ram held; `moving`: a sine, hold, move or dwell
runs (or an exception cut it short: then only the teardown follows); `parked`: disabled
while a person (or the damper's temperature) is waited for, and enabled again after.
A call its state does not allow (a sine before enabling, an enable after the close) is
refused with a `StateError` naming the call and the state, before anything is sent to
the drive.
"""

from __future__ import annotations

import enum
from collections.abc import Iterator
from contextlib import contextmanager

from shockdyno.errors import RigFault


class State(enum.Enum):
    """The session's states: idle (connected, drive not enabled), enabled, moving (a sine or a
    move), parked (disabled for a wait on a person), closed."""

    IDLE = "idle"
    ENABLED = "enabled"
    MOVING = "moving"
    PARKED = "parked"
    CLOSED = "closed"


class StateError(RigFault):
    """A call the session's state does not allow: refused before anything is sent."""


_I, _E, _M, _P, _C = State.IDLE, State.ENABLED, State.MOVING, State.PARKED, State.CLOSED

# Every transition the session makes, from -> to. A stop (disable) may come from any open
# state, and the teardown from every state but closed.
TRANSITIONS: dict[State, frozenset[State]] = {
    _I: frozenset({_I, _E, _C}),
    _E: frozenset({_I, _E, _M, _P, _C}),
    _M: frozenset({_I, _E, _C}),
    _P: frozenset({_I, _E, _C}),
    _C: frozenset(),
}

# The session's calls by kind, and the states each kind may be called in.
ALLOWED: dict[str, frozenset[State]] = {
    "enable": frozenset({_I, _E, _P}),  # enable again after an abort, or after a park
    "motion": frozenset({_E}),  # run_sine, hold_at, move_to, dwell
    "adjust": frozenset({_I, _E}),  # set_clicks, set_adjusters (parks the drive itself)
    "read": frozenset({_I, _E, _P}),  # read_temperature_c
    "park": frozenset({_I, _E}),  # idle: nothing to disable, and nothing enabled after
}


class SessionState:
    """The session's present state, the reason the drive was last disabled, and the checks of
    every call and transition against the tables."""

    def __init__(self) -> None:
        self.state = State.IDLE
        self.disarm_reason = ""  # why the drive was last disabled (or closed)

    @property
    def armed(self) -> bool:
        """This session holds the drive enabled (a disable by anyone else is a trip)."""
        return self.state in (State.ENABLED, State.MOVING)

    @property
    def closed(self) -> bool:
        """Whether the session is closed (every call refused from now on)."""
        return self.state is State.CLOSED

    def require(self, kind: str, call: str) -> None:
        """Refuse `call` (a call of `kind`, ALLOWED's key) unless the state allows it."""
        if self.state in ALLOWED[kind]:
            return
        raise StateError(f"{call} refused: {self.describe()}")

    def describe(self) -> str:
        """The state in words, with the reason the drive was last disabled, for a refusal's
        message."""
        why = f" ({self.disarm_reason})" if self.disarm_reason else ""
        return {
            State.IDLE: "the actuator is not enabled"
            + (f" (disarmed by: {self.disarm_reason})" if self.disarm_reason else " yet"),
            State.ENABLED: "the actuator is enabled",
            State.MOVING: "a motion is running, or an exception cut one short (its stop "
            "command sent; only the close, which stops, centres and disables, may follow)",
            State.PARKED: f"the actuator is not enabled: parked{why}",
            State.CLOSED: f"the rig session is closed{why}",
        }[self.state]

    def to(self, new: State, reason: str = "") -> None:
        """Make a transition of the table; `reason`: why the drive was disabled."""
        if new not in TRANSITIONS[self.state]:
            raise StateError(f"no transition from {self.state.value} to {new.value}")
        self.state = new
        if reason:
            self.disarm_reason = reason

    @contextmanager
    def moving(self, call: str) -> Iterator[None]:
        """A motion: allowed when enabled, and enabled again when it ends, unless its stop
        sequence disabled the drive (idle). An exception that leaves it (a signal, a
        recording that failed, a trip of a move) leaves the session moving: the stop
        command is on the wire, the ramp to centre and the disable are the teardown's."""
        self.require("motion", call)
        self.to(State.MOVING)
        yield
        if self.state is State.MOVING:
            self.to(State.ENABLED)
