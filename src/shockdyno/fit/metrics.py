"""Error measures of the paper's validation (eq. 11-17) and the GA objective (eq. 8).

    E_t  = ε_t  / σ_F,   ε_t²  = ∫ (F_exp - F_model)² dt
    E_x  = ε_x  / σ_F,   ε_x²  = ∫ (F_exp - F_model)² |dx/dt| dt
    E_ẋ  = ε_ẋ  / σ_F,   ε_ẋ²  = ∫ (F_exp - F_model)² |dẋ/dt| dt
    σ_F² = ∫ (F_exp - μ_F)² dt,   μ_F the mean of F_exp over the record.

All integrals run over the whole record passed in (the measured cycles of one test).
E_t is dimensionless (a normalised RMS error); as in the paper, E_x carries the unit
√(m/s) and E_ẋ √(m/s²), because the weights are not normalised. Values are therefore only
comparable between tests of the same motion, which is how Table 4 uses them.

Discretisation:
- dx/dt and dẋ/dt are the velocity and acceleration of `shockdyno.model.differentiate`
  (a cubic Savitzky-Golay filter over 25 ms): a finite difference of an LVDT signal with a
  few µm of noise would make the weights mostly noise, the second derivative especially.
  That needs a uniform time base (ConfigError otherwise).
- Integrals use the trapezoid rule on the sample times, so a record's length in time,
  not its sample count, sets the weight; μ_F is the time average ∫F dt / T by the same rule.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shockdyno.errors import FitError
from shockdyno.model.kinematics import differentiate

FloatArray = NDArray[np.float64]


def _trapz(y: FloatArray, t: FloatArray) -> float:
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t)))


def error_metrics(
    t: ArrayLike,
    x: ArrayLike,
    f_exp: ArrayLike,
    f_model: ArrayLike,
    v: ArrayLike | None = None,
    a: ArrayLike | None = None,
) -> dict[str, float]:
    """E_t, E_x, E_xd (eq. 11-13) of a model force against the measured force.

    v and a (dx/dt, dẋ/dt) may be given when already derived; otherwise they are derived
    from x as the module docstring says.
    """
    ts = np.asarray(t, dtype=float)
    xs = np.asarray(x, dtype=float)
    fe = np.asarray(f_exp, dtype=float)
    fm = np.asarray(f_model, dtype=float)
    if not (ts.shape == xs.shape == fe.shape == fm.shape) or ts.ndim != 1:
        raise FitError("t, x and both forces must be 1-D arrays of one length")
    if ts.size < 3:
        raise FitError("an error measure needs at least three samples")
    if v is None or a is None:
        dv, da = differentiate(ts, xs)
        v = dv if v is None else v
        a = da if a is None else a
    vs = np.abs(np.asarray(v, dtype=float))
    acc = np.abs(np.asarray(a, dtype=float))
    span = float(ts[-1] - ts[0])
    mu = _trapz(fe, ts) / span
    sigma = math.sqrt(_trapz((fe - mu) ** 2, ts))
    if not sigma > 0:
        raise FitError("the measured force is constant: the errors are undefined")
    r2 = (fe - fm) ** 2
    return {
        "E_t": math.sqrt(_trapz(r2, ts)) / sigma,
        "E_x": math.sqrt(_trapz(r2 * vs, ts)) / sigma,
        "E_xd": math.sqrt(_trapz(r2 * acc, ts)) / sigma,
    }


def objective(f_model: ArrayLike, f_exp: ArrayLike) -> float:
    """Eq. 8: the sum over samples of |F_model - F_exp| (N)."""
    return float(np.sum(np.abs(np.asarray(f_model, dtype=float) - np.asarray(f_exp, dtype=float))))
