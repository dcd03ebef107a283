"""The measurement chain: a pure channel delay, a load-cell lag and an LVDT lag.

- delay δ: the force reported at t is the damper's response to the motion at t - δ
  (channels sampled at different instants, a filter's group delay). The motion is
  interpolated, so tens of ms are as accurate as one.
- load-cell lag τ_F: the reported force is the true one through τ_F dF'/dt = F - F'.
- LVDT lag τ_x: the recorded x lags the rod; the rod is x + τ_x ẋ (the lag inverted).

Off: all three 0. At 0.5-1.5 Hz all three shift the loop by about the same time
(τ_F + δ - τ_x) and attenuate by (ωτ)²/2 < 0.05 %, so a sweep pins their sum: the fit
frees δ and holds the lags unless named (`--terms sensor_lag.load_cell_lag_s`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import ClassVar

import numpy as np

from shockdyno.model.composite import MOTION, SENSOR, Evaluation, FloatArray, Term, Work
from shockdyno.model.filters import delayed, first_order_lag
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading


class SensorLag(Term):
    """The measurement chain: the force channel's delay behind the motion, the load cell's
    first-order lag and the LVDT's. A sensor term, not carried to a car."""

    name = "sensor_lag"
    stage = SENSOR
    stages = (MOTION, SENSOR)
    sensor = True
    stateful = True
    summary = "measurement chain: channel delay, load-cell lag, LVDT lag"
    follows = ("lag",)
    time_shift: ClassVar[dict[str, float]] = {
        "delay_s": 1.0,
        "load_cell_lag_s": 1.0,
        "lvdt_lag_s": -1.0,
    }
    separated_by: ClassVar[dict[str, str]] = {
        "compressibility": (
            "tests at other gas pressures (air's lag falls as the charge rises; a sensor's "
            "does not) or a wider frequency range (a pure delay shifts every frequency by one "
            "time)"
        ),
        "friction": "slow tests (below 25 mm/s) where friction dominates",
    }
    PARAMS = (
        # A force channel is read at or after the motion it answers, never before it: a
        # delay below 0 (the force leading the rod) is no sensor's. A motion channel that
        # lags is the LVDT's lag, its own parameter.
        Param(
            "delay_s",
            "s",
            nominal=0.0,
            lo=0.0,
            hi=0.05,
            scale=1e-3,
            off=0.0,
            doc="force behind motion",
        ),
        # A load-cell amplifier slower than 20 ms (8 Hz) would not be on a damper dyno.
        Param(
            "load_cell_lag_s", "s", nominal=0.0, lo=0.0, hi=0.02, scale=1e-3, off=0.0, free=False
        ),
        Param("lvdt_lag_s", "s", nominal=0.0, lo=0.0, hi=0.02, scale=1e-3, off=0.0, free=False),
    )

    def describe(self, r: Reading) -> str:
        """The total time the force lags the motion (ms), and the delay and lags the data moved;
        a delay and an LVDT lag both moved are read as their difference."""
        shift = r.v("delay_s") + r.v("load_cell_lag_s") - r.v("lvdt_lag_s")
        # A delay of the force and a lag of the LVDT differ only beyond first order in the
        # shift (x(t - δ) ≈ x - δ ẋ against x + τ_x ẋ), far below the noise at a few ms, so
        # a sweep reads δ - τ_x: both "moved" is a ridge of the fit, not two sensors.
        ridge = r.moved("delay_s") and r.moved("lvdt_lag_s")
        parts = [
            f"{label} {1e3 * r.v(key):.2g}{r.sd(key, 1e3)} ms"
            for key, label in (
                ("delay_s", "pure delay"),
                ("load_cell_lag_s", "load-cell lag"),
                ("lvdt_lag_s", "LVDT lag"),
            )
            if r.moved(key) and not (ridge and key != "load_cell_lag_s")
        ]
        if ridge:
            both = 1e3 * (r.v("delay_s") - r.v("lvdt_lag_s"))
            parts.append(
                f"pure delay less LVDT lag {both:.2g} ms: a sweep cannot tell a force delay "
                "from an LVDT lag"
            )
        detail = f" ({', '.join(parts)})" if parts else ""
        if shift < 0:
            return (
                f"sensor lag: the motion channel lags the force by {-1e3 * shift:.3g} ms in "
                f"all{detail}"
            )
        return f"sensor lag: force lags the motion by {1e3 * shift:.3g} ms in all{detail}"

    def nesting_free(self) -> tuple[str, ...]:
        """Delay and both lags: only sharp events tell a delay from a lag, so the diagnosis tries
        all three."""
        # A delay and a lag differ only at sharp events (the friction flip at reversal):
        # the diagnosis tries both, the fit by default only the delay.
        return ("delay_s", "load_cell_lag_s", "lvdt_lag_s")

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        """Load-cell lags of 0, 1, 3 and 8 ms."""
        # A lag and a delay trade off near zero; start from a few lags so the refit
        # does not stall at the bound with the delay doing all the work.
        return [{"load_cell_lag_s": t} for t in (0.0, 0.001, 0.003, 0.008)]

    def full_rate(self, p: Mapping[str, float], free: Iterable[str]) -> bool:
        """Only a load-cell lag (set or freed) needs the recording's own rate."""
        return p["load_cell_lag_s"] > 0 or "load_cell_lag_s" in set(free)

    def carries_state(self, p: Mapping[str, float], free: Iterable[str]) -> bool:
        """Only the load cell's lag carries state; the delay and the LVDT lag act sample by
        sample."""
        # The delay and the LVDT lag act on the motion sample by sample: a force then
        # follows its own (delayed) motion alone. Only the load cell's lag carries state.
        return self.full_rate(p, free)

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        """At MOTION, shift the motion the damper sees (LVDT lag inverted, then the delay); at
        SENSOR, lag the total force through the load cell and return the lag's state."""
        if stage == MOTION:
            tx = p["lvdt_lag_s"]
            if tx:
                w.x = w.x + tx * w.v
                w.v = w.v + tx * w.a
            delay = p["delay_s"]
            if delay:
                x, v, a = w.x, w.v, w.a
                w.x = delayed(x, v, delay, w.starts, w.dt_s)
                w.v = delayed(v, a, delay, w.starts, w.dt_s)
                w.a = delayed(a, np.zeros_like(a), delay, w.starts, w.dt_s)
            return None
        tau = p["load_cell_lag_s"]
        if not tau:
            return None
        assert w.total is not None
        lagged, state = first_order_lag(
            w.total, tau, w.starts, w.dt_s, carry, periodic=w.inputs.periodic
        )
        w.add_part(self.name, lagged - w.total)
        return state
