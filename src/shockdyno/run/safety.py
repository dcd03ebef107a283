"""Soft limits checked on every DAQ sample, and the events that record what safety did.

The checks are vectorised over each SampleBlock. Velocity is estimated over a short
window of samples (carried across blocks) so one quantisation step of the LVDT cannot
trip it. Trips sit `trip_margin` beyond the limits that a test's plan must respect, so a
sine planned at the limit does not trip on servo overshoot or noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shockdyno.errors import RigFault
from shockdyno.rig.config import Limits
from shockdyno.samples import SampleBlock

VELOCITY_WINDOW = 5  # samples


@dataclass(frozen=True)
class SafetyEvent:
    """Something safety did or saw, at DAQ time `t_s` (s): its kind (`travel`, `force`,
    `link_lost`, `enable`, ...) and a one-line message."""

    t_s: float  # DAQ time of the event (the last sample seen when it was not a sample)
    kind: str
    message: str


class SafetyTrip(RigFault):
    """A limit breach, frozen DAQ, lost link or actuator fault: the session must stop."""

    def __init__(self, event: SafetyEvent) -> None:
        super().__init__(event.message)
        self.event = event


class LimitMonitor:
    """Checks every sample against the trips: |displacement|, |force| and |velocity| (from a
    short window of samples) beyond the limits plus `trip_margin`, temperature above its limit."""

    def __init__(self, limits: Limits) -> None:
        self.limits = limits
        m = 1.0 + limits.trip_margin
        self.travel_trip_m = limits.travel_m * m
        self.force_trip_n = limits.force_n * m
        self.velocity_trip_m_s = limits.velocity_m_s * m
        self._x_hist = np.zeros(0)
        self._t_hist = np.zeros(0)

    def reset(self) -> None:
        """Forget the samples carried for the velocity window (a new stream starts)."""
        self._x_hist = np.zeros(0)
        self._t_hist = np.zeros(0)

    def check(self, block: SampleBlock) -> SafetyEvent | None:
        """The first breach in the block (by sample), or None."""
        if not len(block):
            return None
        x, f, temp, t = block.displacement_m, block.force_n, block.temperature_c, block.t_s
        xs = np.concatenate((self._x_hist, x))
        ts = np.concatenate((self._t_hist, t))
        w = VELOCITY_WINDOW
        v = np.zeros(len(x))
        if xs.size > w:
            dv = (xs[w:] - xs[:-w]) / (ts[w:] - ts[:-w])
            v[len(x) - dv.size :] = dv[-len(x) :]
        self._x_hist, self._t_hist = xs[-w:], ts[-w:]
        lim = self.limits
        checks = (
            ("travel", np.abs(x) > self.travel_trip_m, x, "m", lim.travel_m),
            ("force", np.abs(f) > self.force_trip_n, f, "N", lim.force_n),
            ("velocity", np.abs(v) > self.velocity_trip_m_s, v, "m/s", lim.velocity_m_s),
            ("temperature", temp > lim.temperature_c, temp, "°C", lim.temperature_c),
        )
        first: tuple[int, str, float, str, float] | None = None
        for kind, mask, values, unit, limit in checks:
            if mask.any():
                i = int(np.argmax(mask))
                if first is None or i < first[0]:
                    first = (i, kind, float(values[i]), unit, limit)
        if first is None:
            return None
        i, kind, value, unit, limit = first
        return SafetyEvent(
            float(t[i]), kind, f"{kind} limit: {value:.4g} {unit} (limit {limit:g} {unit})"
        )
