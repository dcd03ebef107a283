"""Damper force (eq. 1) for the proposed model and Talbott's: the paper's model alone.

With the rebound-chamber pressure p_r = p_c - Δp, eq. 1 becomes

    F = m_p ẍ + p_c A_rod + Δp A_r + F_f sgn(ẋ),

i.e. inertia, gas force on the rod, the piston pressure drop on the annulus, and friction.
Signs follow the project: x > 0 is compression, F > 0 resists compression. sgn(ẋ) is
smoothed to tanh(ẋ / v_f) with v_f = 1 mm/s so that velocity noise near reversal does
not toggle the full friction force sample by sample.

The proposed model uses separate bleed areas A_bc (Δp > 0, compression) and A_bt
(Δp < 0, rebound); Talbott's uses one A_b for both. Everything else is shared.

These functions are `DamperModel(spec)` with no terms (model/composite.py), the one model
that extra physics plugs into.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shockdyno.model.composite import ATMOSPHERE_PA, DamperModel, ModelInputs
from shockdyno.model.kinematics import DEFAULT_WINDOW_S, differentiate, sample_interval
from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]

__all__ = ["ATMOSPHERE_PA", "ForceBreakdown", "damper_force", "evaluate", "talbott_force"]


@dataclass(frozen=True)
class ForceBreakdown:
    """The paper's model at each sample: `force` (N, positive resisting compression) and its
    parts (inertia, gas, hydraulic, friction; N), Δp across the piston `dp` (Pa, positive in
    compression), the compression- and rebound-chamber pressures `p_c`, `p_r` (Pa, absolute), and
    `bleed_share`."""

    force: FloatArray
    dp: FloatArray
    p_c: FloatArray
    p_r: FloatArray
    f_inertia: FloatArray
    f_gas: FloatArray
    f_hydraulic: FloatArray
    f_friction: FloatArray
    bleed_share: FloatArray  # fraction of the pressure-driven flow through the bleed


def _inputs(x: ArrayLike, v: ArrayLike, a: ArrayLike) -> ModelInputs:
    return ModelInputs.single(x, v, a)


def evaluate(
    spec: DamperSpec,
    x: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    a_bc: ArrayLike,
    a_bt: ArrayLike,
) -> ForceBreakdown:
    """The force and every intermediate of the paper's model, per sample."""
    inp = _inputs(x, v, a)
    ev = DamperModel(spec).evaluate(inp, a_bc, a_bt)
    n = inp.size
    bc = np.broadcast_to(np.asarray(a_bc, float), (n,))
    bt = np.broadcast_to(np.asarray(a_bt, float), (n,))
    bleed_area = np.where(ev.dp >= 0, bc, bt)
    q_demand = (spec.annulus_area_m2 - spec.couette_area_m2) * inp.v
    q_bleed = (
        spec.discharge_coefficient
        * bleed_area
        * np.sqrt(2 * np.abs(ev.dp) / spec.oil_density_kg_m3)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(np.abs(q_demand) > 0, q_bleed / np.abs(q_demand), 1.0)
    c = ev.components
    return ForceBreakdown(
        force=ev.force,
        dp=ev.dp,
        p_c=ev.p_c,
        p_r=ev.p_c - ev.dp,
        f_inertia=c["inertia"],
        f_gas=c["gas"],
        f_hydraulic=c["hydraulic"],
        f_friction=c["coulomb"],
        bleed_share=np.clip(share, 0.0, 1.0),
    )


def damper_force(
    spec: DamperSpec,
    x: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    a_bc: ArrayLike,
    a_bt: ArrayLike,
) -> FloatArray:
    """Proposed model: force (N) for displacement x, velocity v, acceleration a."""
    return DamperModel(spec).force(_inputs(x, v, a), a_bc, a_bt)


def talbott_force(
    spec: DamperSpec,
    x: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    a_b: ArrayLike,
) -> FloatArray:
    """Talbott's baseline: one bleed area for both strokes, otherwise the same physics."""
    return damper_force(spec, x, v, a, a_b, a_b)


def force_from_displacement(
    model: DamperSpec | DamperModel,
    t: ArrayLike,
    x: ArrayLike,
    a_bc: ArrayLike,
    a_bt: ArrayLike,
    window_s: float = DEFAULT_WINDOW_S,
    temperature_c: ArrayLike | None = None,
) -> FloatArray:
    """The paper's use: measured displacement in, force out (velocity derived robustly)."""
    m = model if isinstance(model, DamperModel) else DamperModel(model)
    ts = np.asarray(t, dtype=float)
    xs = np.asarray(x, dtype=float)
    v, a = differentiate(ts, xs, window_s)
    inp = ModelInputs.single(xs, v, a, sample_interval(ts), temperature_c)
    return m.force(inp, a_bc, a_bt)
