"""A smooth force of displacement for what no named physics explains (open set).

F = s(x): piecewise-linear between K knots evenly spread over [x_lo, x_hi] (the
recording's stroke), flat beyond. A bump stop, a top-out spring or a seal that grips
harder at one end shows here. The fit regularises it: second differences of the knot
values are penalised (smoothness), and so is their mean, which the fitted gas pressure
already sets. Off: every knot 0.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from shockdyno.model.composite import FORCE, FloatArray, Term, Work
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading

N_KNOTS = 8
SMOOTHING = 0.3  # N of penalty residual per N of second difference
MEAN_WEIGHT = 1.0


class PositionForce(Term):
    """A smooth force of displacement, piecewise linear through 8 knots over the recorded stroke,
    for what no named physics explains."""

    name = "position_force"
    stage = FORCE + 5
    summary = "smooth force of displacement (bump stop, top-out, position-dependent seal)"
    follows = ("displacement", "position")
    open_set = True
    PARAMS = (
        Param("x_lo_m", "m", nominal=-0.035, lo=-1.0, hi=1.0, scale=0.01, off=-0.035, free=False),
        Param("x_hi_m", "m", nominal=0.035, lo=-1.0, hi=1.0, scale=0.01, off=0.035, free=False),
        *(
            Param(
                f"f{k}_n",
                "N",
                nominal=0.0,
                lo=-5000.0,
                hi=5000.0,
                scale=20.0,
                off=0.0,
                doc=f"force at knot {k}",
            )
            for k in range(N_KNOTS)
        ),
    )

    def describe(self, r: Reading) -> str:
        """The largest knot force and where it is (x, compression positive), in the reader's
        units."""
        (fn, fl), (ln, ll) = r.force, r.length
        knots = [r.v(f"f{k}_n") for k in range(N_KNOTS)]
        lo, hi = r.v("x_lo_m"), r.v("x_hi_m")
        k = max(range(N_KNOTS), key=lambda i: abs(knots[i]))
        x = lo + (hi - lo) * k / (N_KNOTS - 1)
        return (
            f"a force of position no named physics explains: up to {fn * knots[k]:+.3g} {fl} "
            f"at x = {ln * x:+.3g} {ll} (bump stop, top-out or a seal that grips at one end?)"
        )

    def placed(self, x: FloatArray) -> dict[str, float]:
        """The knots' span from the data: the recording's smallest and largest x (m)."""
        return {"x_lo_m": float(np.min(x)), "x_hi_m": float(np.max(x))}

    @staticmethod
    def knot_values(p: Mapping[str, float]) -> np.ndarray:
        """The force at each knot (N)."""
        return np.array([p[f"f{k}_n"] for k in range(N_KNOTS)])

    @staticmethod
    def knots(p: Mapping[str, float]) -> np.ndarray:
        """The knots' positions (m), evenly from x_lo_m to x_hi_m."""
        return np.linspace(p["x_lo_m"], p["x_hi_m"], N_KNOTS)

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        """Add s(x) (N), linear between the knots and flat beyond them, at the FORCE stage."""
        w.add_part(self.name, np.interp(w.x, self.knots(p), self.knot_values(p)))
        return None

    def penalty(self, p: Mapping[str, float]) -> FloatArray:
        """Residuals (N) for smoothness (the knots' second differences) and for their mean, which
        the gas pressure already sets."""
        c = self.knot_values(p)
        return np.concatenate([SMOOTHING * np.diff(c, 2), [MEAN_WEIGHT * float(np.mean(c))]])
