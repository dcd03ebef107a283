"""Damper force (eq. 1) for the proposed model and Talbott's, with pluggable extra physics.

With the rebound-chamber pressure p_r = p_c - Δp, eq. 1 becomes

    F = m_p ẍ + p_c A_rod + Δp A_r + F_f sgn(ẋ),

i.e. inertia, gas force on the rod, the piston pressure drop on the annulus, and friction.
Signs follow the project: x > 0 is compression, F > 0 resists compression. sgn(ẋ) is
smoothed to tanh(ẋ / v_f) with v_f = 1 mm/s so that velocity noise near reversal does
not toggle the full friction force sample by sample.

The proposed model uses separate bleed areas A_bc (Δp > 0, compression) and A_bt
(Δp < 0, rebound); Talbott's uses one A_b for both. Everything else is shared.

Extra physics (compressibility, temperature, richer friction, cavitation, ...) plugs in
through `PhysicsTerm`: each term sees the whole `ModelState` before the flow solve (it may
change the flow demand, per-sample bleed areas or leak conductance, or set Δp itself,
e.g. by integrating a compressible chamber) and after it (it may change pressures and
force components). The core never needs to know what a term models.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shockdyno.model.flow import solve_pressure_drop
from shockdyno.model.gas import compression_pressure
from shockdyno.model.kinematics import DEFAULT_WINDOW_S, differentiate
from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]

ATMOSPHERE_PA = 101_325.0  # pressures are absolute (the gas law needs it)


@dataclass
class ModelState:
    """Everything the force computation knows, per sample. Terms may edit it in place."""

    spec: DamperSpec
    t: FloatArray | None
    x: FloatArray
    v: FloatArray
    a: FloatArray
    bleed_compression_m2: FloatArray
    bleed_rebound_m2: FloatArray
    k_leak: FloatArray
    q_demand: FloatArray  # flow the pressure drop must drive, m³/s (> 0 compression)
    dp: FloatArray | None = None  # p_c - p_r, Pa; a term may set it to skip the solve
    p_c: FloatArray | None = None
    p_r: FloatArray | None = None
    f_inertia: FloatArray | None = None
    f_gas: FloatArray | None = None
    f_hydraulic: FloatArray | None = None
    f_friction: FloatArray | None = None
    extra: dict[str, FloatArray] = field(default_factory=dict)  # forces added by terms

    @property
    def force(self) -> FloatArray:
        parts = [self.f_inertia, self.f_gas, self.f_hydraulic, self.f_friction]
        total = np.zeros_like(self.x)
        for part in [*parts, *self.extra.values()]:
            if part is not None:
                total = total + part
        return total


@runtime_checkable
class PhysicsTerm(Protocol):
    """A piece of physics the paper's model leaves out."""

    name: str

    def before_flow(self, state: ModelState) -> None: ...

    def after_flow(self, state: ModelState) -> None: ...


@dataclass(frozen=True)
class ForceBreakdown:
    force: FloatArray
    dp: FloatArray
    p_c: FloatArray
    p_r: FloatArray
    f_inertia: FloatArray
    f_gas: FloatArray
    f_hydraulic: FloatArray
    f_friction: FloatArray
    bleed_share: FloatArray  # fraction of the pressure-driven flow through the bleed


def _as_samples(value: ArrayLike, shape: tuple[int, ...]) -> FloatArray:
    return np.ascontiguousarray(np.broadcast_to(np.asarray(value, dtype=float), shape))


def _state(
    spec: DamperSpec,
    x: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    a_bc: ArrayLike,
    a_bt: ArrayLike,
    t: ArrayLike | None,
) -> ModelState:
    xs = np.asarray(x, dtype=float)
    vs = _as_samples(v, xs.shape)
    return ModelState(
        spec=spec,
        t=None if t is None else np.asarray(t, dtype=float),
        x=xs,
        v=vs,
        a=_as_samples(a, xs.shape),
        bleed_compression_m2=_as_samples(a_bc, xs.shape),
        bleed_rebound_m2=_as_samples(a_bt, xs.shape),
        k_leak=_as_samples(spec.leak_conductance_m3_s_pa, xs.shape),
        q_demand=(spec.annulus_area_m2 - spec.couette_area_m2) * vs,
    )


def solve_state(state: ModelState, terms: Sequence[PhysicsTerm] = ()) -> ModelState:
    """Run the model on a prepared state: terms, flow solve, pressures, forces."""
    spec = state.spec
    for term in terms:
        term.before_flow(state)
    if state.dp is None:
        q = state.q_demand
        comp = q > 0
        dp = np.zeros_like(q)
        common = (spec.discharge_coefficient, spec.oil_density_kg_m3)
        if np.any(comp):
            dp[comp] = solve_pressure_drop(
                q[comp],
                state.bleed_compression_m2[comp],
                spec.compression_valve,
                *common,
                state.k_leak[comp],
            )
        reb = q < 0
        if np.any(reb):
            dp[reb] = -solve_pressure_drop(
                q[reb],
                state.bleed_rebound_m2[reb],
                spec.rebound_valve,
                *common,
                state.k_leak[reb],
            )
        state.dp = dp
    state.p_c = compression_pressure(spec, state.x, state.a)
    state.p_r = state.p_c - state.dp
    state.f_inertia = spec.piston_rod_mass_kg * state.a
    state.f_gas = (state.p_c - ATMOSPHERE_PA) * spec.rod_area_m2  # air pushes the rod back in
    state.f_hydraulic = state.dp * spec.annulus_area_m2
    state.f_friction = spec.friction_n * np.tanh(state.v / spec.friction_velocity_m_s)
    for term in terms:
        term.after_flow(state)
    return state


def evaluate(
    spec: DamperSpec,
    x: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    a_bc: ArrayLike,
    a_bt: ArrayLike,
    terms: Sequence[PhysicsTerm] = (),
    t: ArrayLike | None = None,
) -> ForceBreakdown:
    """The force and every intermediate of the model, per sample."""
    s = solve_state(_state(spec, x, v, a, a_bc, a_bt, t), terms)
    assert s.dp is not None and s.p_c is not None and s.p_r is not None
    assert s.f_inertia is not None and s.f_gas is not None
    assert s.f_hydraulic is not None and s.f_friction is not None
    bleed_area = np.where(s.dp >= 0, s.bleed_compression_m2, s.bleed_rebound_m2)
    q_bleed = (
        spec.discharge_coefficient * bleed_area * np.sqrt(2 * np.abs(s.dp) / spec.oil_density_kg_m3)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(np.abs(s.q_demand) > 0, q_bleed / np.abs(s.q_demand), 1.0)
    return ForceBreakdown(
        force=s.force,
        dp=s.dp,
        p_c=s.p_c,
        p_r=s.p_r,
        f_inertia=s.f_inertia,
        f_gas=s.f_gas,
        f_hydraulic=s.f_hydraulic,
        f_friction=s.f_friction,
        bleed_share=np.clip(share, 0.0, 1.0),
    )


def damper_force(
    spec: DamperSpec,
    x: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    a_bc: ArrayLike,
    a_bt: ArrayLike,
    terms: Sequence[PhysicsTerm] = (),
    t: ArrayLike | None = None,
) -> FloatArray:
    """Proposed model: force (N) for displacement x, velocity v, acceleration a."""
    return solve_state(_state(spec, x, v, a, a_bc, a_bt, t), terms).force


def talbott_force(
    spec: DamperSpec,
    x: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    a_b: ArrayLike,
    terms: Sequence[PhysicsTerm] = (),
    t: ArrayLike | None = None,
) -> FloatArray:
    """Talbott's baseline: one bleed area for both strokes, otherwise the same physics."""
    return damper_force(spec, x, v, a, a_b, a_b, terms, t)


def force_from_displacement(
    spec: DamperSpec,
    t: ArrayLike,
    x: ArrayLike,
    a_bc: ArrayLike,
    a_bt: ArrayLike,
    terms: Sequence[PhysicsTerm] = (),
    window_s: float = DEFAULT_WINDOW_S,
) -> FloatArray:
    """The paper's use: measured displacement in, force out (velocity derived robustly)."""
    ts = np.asarray(t, dtype=float)
    xs = np.asarray(x, dtype=float)
    v, a = differentiate(ts, xs, window_s)
    return damper_force(spec, xs, v, a, a_bc, a_bt, terms, ts)
