"""Physics the paper's model leaves out, as `PhysicsTerm`s (see docs/scenarios.md).

Stateful terms (compressibility, thermal, load-cell lag) are causal linear filters run
with `scipy.signal.lfilter` and carried state, so feeding a record in one call or in
any split gives the same numbers (the simulated rig relies on this for identical frames
at any speed). Call `reset()` before reusing a stateful term on an unrelated record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from shockdyno.errors import ConfigError
from shockdyno.model.damper import ATMOSPHERE_PA, ModelState

FloatArray = NDArray[np.float64]
KELVIN = 273.15


def _dt(state: ModelState, sample_rate_hz: float) -> float:
    if state.t is not None and state.t.size >= 2:
        # Rounded so that any slice of one uniform record gives bit-identical filter gains.
        return float(f"{(state.t[-1] - state.t[0]) / (state.t.size - 1):.9g}")
    return 1.0 / sample_rate_hz


def first_order_lag(
    u: FloatArray, k: float, zi: FloatArray | None
) -> tuple[FloatArray, FloatArray]:
    """y[n] = y[n-1] + k (u[n] - y[n-1]), starting from u[0] when there is no state."""
    if zi is None:
        zi = np.array([(1 - k) * u[0]]) if u.size else np.zeros(1)
    y, zf = lfilter([k], [1.0, -(1.0 - k)], u, zi=zi)
    return np.asarray(y, float), np.asarray(zf, float)


@dataclass
class SealFriction:
    """Stribeck friction with stiction, replacing the model's constant Coulomb friction.

    F_f = (F_c + (F_s − F_c) exp(−(v/v_s)²)) tanh(v/v_ε) + c_v v
    """

    static_n: float = 60.0
    coulomb_n: float = 35.0
    stribeck_velocity_m_s: float = 0.005
    viscous_n_s_m: float = 40.0
    smoothing_m_s: float = 0.0005
    name: str = "seal_friction"

    def before_flow(self, state: ModelState) -> None:
        pass

    def after_flow(self, state: ModelState) -> None:
        v = state.v
        level = self.coulomb_n + (self.static_n - self.coulomb_n) * np.exp(
            -((v / self.stribeck_velocity_m_s) ** 2)
        )
        state.f_friction = level * np.tanh(v / self.smoothing_m_s) + self.viscous_n_s_m * v


@dataclass
class Cavitation:
    """The rebound chamber cannot fall below the oil's vapour pressure.

    In a monotube the compression chamber sits at gas pressure, so it is the rebound
    chamber, behind the piston on a fast compression stroke, that cavitates when the
    pressure drop exceeds the gas pressure:
    p_r = max(p_c − Δp, p_v); Δp = p_c − p_r; F_h = Δp A_r. Compression force saturates.
    """

    vapour_pressure_pa: float = 3000.0
    name: str = "cavitation"

    def before_flow(self, state: ModelState) -> None:
        pass

    def after_flow(self, state: ModelState) -> None:
        assert state.p_c is not None and state.p_r is not None
        p_r = np.maximum(state.p_r, self.vapour_pressure_pa)
        state.p_r = p_r
        state.dp = state.p_c - p_r
        state.f_hydraulic = state.dp * state.spec.annulus_area_m2


@dataclass
class Compressibility:
    """Oil compressibility with entrained air: the pressure drop lags the static solution.

    1/β_eff = (1 − α)/β_oil + α/p_gas   (Wood's mixture law at the gas pressure)
    τ = V / (β_eff G)                   (chamber volume V, valve conductance G = ∂q/∂Δp)
    Δp' = Δp_static low-passed with time constant τ (first order).
    """

    bulk_modulus_pa: float = 1.5e9
    air_fraction: float = 0.02
    chamber_volume_m3: float = 1.0e-4
    conductance_m3_s_pa: float = 2.0e-11
    sample_rate_hz: float = 1000.0
    name: str = "compressibility"
    _zi: FloatArray | None = field(default=None, repr=False)

    def time_constant_s(self, gas_pressure_pa: float) -> float:
        a = self.air_fraction
        beta = 1.0 / ((1 - a) / self.bulk_modulus_pa + a / gas_pressure_pa)
        return self.chamber_volume_m3 / (beta * self.conductance_m3_s_pa)

    def reset(self) -> None:
        self._zi = None

    def before_flow(self, state: ModelState) -> None:
        pass

    def after_flow(self, state: ModelState) -> None:
        assert state.dp is not None and state.p_c is not None
        tau = self.time_constant_s(state.spec.gas_pressure_pa)
        k = 1.0 - math.exp(-_dt(state, self.sample_rate_hz) / tau)
        dp, self._zi = first_order_lag(state.dp, k, self._zi)
        state.dp = dp
        state.p_r = state.p_c - dp
        state.f_hydraulic = dp * state.spec.annulus_area_m2


@dataclass
class ThermalViscosity:
    """Oil heats up as the damper works; viscosity falls; the gas spring stiffens.

    C dT/dt = c_eq v² − h (T − T_amb)        (power ≈ c_eq v², no force feedback)
    ν(T) = ν_ref exp(−b (T − T_ref))         → leak conductance × exp(b (T − T_ref))
    p_c × (T + 273.15)/(T_ref + 273.15)      (gas at the oil's temperature)
    """

    heat_capacity_j_k: float = 900.0
    cooling_w_k: float = 3.0
    ambient_c: float = 40.0
    start_c: float = 40.0
    dissipation_n_s_m: float = 3000.0
    viscosity_coeff_per_k: float = 0.025
    reference_c: float = 40.0
    sample_rate_hz: float = 1000.0
    name: str = "thermal"
    temperature_c: FloatArray = field(default_factory=lambda: np.zeros(0), repr=False)
    _zi: FloatArray | None = field(default=None, repr=False)

    def reset(self) -> None:
        self._zi = None

    def before_flow(self, state: ModelState) -> None:
        dt = _dt(state, self.sample_rate_hz)
        g = 1.0 - dt * self.cooling_w_k / self.heat_capacity_j_k
        gain = dt * self.dissipation_n_s_m / self.heat_capacity_j_k
        zi = self._zi if self._zi is not None else np.array([g * (self.start_c - self.ambient_c)])
        rise, zf = lfilter([gain], [1.0, -g], state.v**2, zi=zi)
        self._zi = np.asarray(zf, float)
        self.temperature_c = self.ambient_c + np.asarray(rise, float)
        state.k_leak = state.k_leak * np.exp(
            self.viscosity_coeff_per_k * (self.temperature_c - self.reference_c)
        )

    def after_flow(self, state: ModelState) -> None:
        assert state.p_c is not None and state.dp is not None
        ratio = (self.temperature_c + KELVIN) / (self.reference_c + KELVIN)
        state.p_c = state.p_c * ratio
        state.p_r = state.p_c - state.dp
        state.f_gas = (state.p_c - ATMOSPHERE_PA) * state.spec.rod_area_m2


@dataclass
class LoadCellLag:
    """The load cell (and its amplifier) reads the force through a first-order lag τ."""

    time_constant_s: float = 0.002
    sample_rate_hz: float = 1000.0
    name: str = "load_cell_lag"
    _zi: FloatArray | None = field(default=None, repr=False)

    def reset(self) -> None:
        self._zi = None

    def before_flow(self, state: ModelState) -> None:
        pass

    def after_flow(self, state: ModelState) -> None:
        state.extra.pop(self.name, None)
        total = state.force
        k = 1.0 - math.exp(-_dt(state, self.sample_rate_hz) / self.time_constant_s)
        lagged, self._zi = first_order_lag(total, k, self._zi)
        state.extra[self.name] = lagged - total


TERM_KINDS: dict[str, type] = {
    "seal_friction": SealFriction,
    "cavitation": Cavitation,
    "compressibility": Compressibility,
    "thermal": ThermalViscosity,
    "load_cell_lag": LoadCellLag,
}


def make_term(kind: str, params: dict[str, Any], where: str = "term") -> Any:
    """Build a term from a scenario table; unknown kinds or keys are ConfigErrors."""
    cls = TERM_KINDS.get(kind)
    if cls is None:
        raise ConfigError(f"{where}: unknown kind {kind!r} (one of {', '.join(TERM_KINDS)})")
    allowed = {f.name for f in fields(cls) if not f.name.startswith("_") and f.name != "name"}
    allowed.discard("temperature_c")
    for key, value in params.items():
        if key not in allowed:
            raise ConfigError(f"{where}: unknown key {key!r} for {kind}")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{where}: {key} must be a number, got {value!r}")
        if not math.isfinite(value) or value < 0:
            raise ConfigError(f"{where}: {key} must be >= 0, got {value!r}")
    return cls(**{k: float(v) for k, v in params.items()})
