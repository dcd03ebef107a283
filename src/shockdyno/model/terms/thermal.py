"""Temperature: the oil's viscosity falls and the gas spring stiffens as the damper warms.

    ν(T) = ν_ref exp(-b (T - T_ref))  →  leak conductance × exp(b (T - T_ref)),
                                          the bleed's and the stacks' lands ÷ exp(b (T - T_ref))
    p_c × (1 + g ((T + 273.15)/(T_ref + 273.15) - 1))     (gas at the oil's temperature)
    Δp × exp(-d (T - T_ref))                               (damping fades as the oil thins)

T is the oil's temperature. A recording's temperature channel is the body's (a sensor on
the outside of the tube), and the oil that heats the body runs ahead of it: the body's heat
balance C_b dT_b/dt = G (T_oil - T_b) - (loss to ambient) gives T_oil ≈ T_b + L dT_b/dt with
the lead L = C_b/G (the loss folds into the coefficients' reference), dT_b/dt each test's
slope of the channel. Off: L = 0, the channel as the oil's. Without a channel an energy
balance estimates it, C dT/dt = c_eq v² - h (T - T_ref), written as a first-order lag of
k τ v² with τ = C/h and k = c_eq/C, starting each test at T_ref (the sim-rig carries it
across a whole session). Off: b = g = d = 0. The leak's share of the flow is small, so b
is weakly identified; the gas part g is the strong signature (force offset that follows
T). d stands for what the paper's turbulent orifices leave out (a discharge coefficient
and shim-stack laminar flow that depend on viscosity): the fit holds it at 0 unless named
(`thermal.damping_coeff_per_k`); the diagnosis tries it.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import ClassVar

import numpy as np

from shockdyno.model.composite import CHAMBER, PRESSURE, FloatArray, Term, Work
from shockdyno.model.filters import first_order_lag
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading
from shockdyno.model.spec import DamperSpec

KELVIN = 273.15
DAMPING_RISE_PER_K = 0.005  # how far a fit's damping may rise per K (noise, not physics)


class Thermal(Term):
    """The oil's temperature (°C: the channel plus its lead, or an energy balance without one)
    acting on the leak and bleed viscosity, the gas pressure and Δp."""

    name = "thermal"
    stage = CHAMBER + 5  # after the gas spring: the temperature scales the gas it gives
    stages = (CHAMBER + 5, PRESSURE - 5)  # and Δp, before a lag or a clamp acts on it
    stateful = True
    summary = "temperature: viscosity falls, gas pressure rises with the oil's temperature"
    follows = ("temperature",)
    place = "session"  # within a test it scales the damper's force; between tests it moves
    separated_by: ClassVar[dict[str, str]] = {
        "position_force": "a test held at constant temperature"
    }
    PARAMS = (
        Param(
            "gas_coupling",
            "1",
            nominal=1.0,
            lo=0.0,
            hi=3.0,
            scale=1.0,
            off=0.0,
            doc="1: gas at the oil's temperature",
        ),
        Param(
            "viscosity_coeff_per_k",
            "1/K",
            nominal=0.025,
            lo=0.0,
            hi=0.1,
            scale=0.01,
            off=0.0,
            doc="ν falls b per K",
        ),
        Param(
            "damping_coeff_per_k",
            "1/K",
            nominal=0.0,
            lo=-0.05,
            hi=0.05,
            scale=0.005,
            off=0.0,
            free=False,
            doc="Δp falls d per K",
        ),
        Param(
            "oil_lead_s",
            "s",
            nominal=0.0,  # on as off: a simulated rig's channel is its oil's own
            lo=0.0,
            hi=1000.0,
            scale=50.0,
            off=0.0,
            doc="oil over a measured body: T_oil = T_body + lead · dT_body/dt",
        ),
        Param(
            "reference_c", "°C", nominal=40.0, lo=-40.0, hi=150.0, scale=10.0, off=40.0, free=False
        ),
        Param(
            "heat_rate_k_s_m2",
            "K·s/m²",
            nominal=3.33,
            lo=0.0,
            hi=100.0,
            scale=1.0,
            off=3.33,
            free=False,
        ),
        Param(
            "cooling_time_s",
            "s",
            nominal=300.0,
            lo=1.0,
            hi=1.0e5,
            scale=100.0,
            off=300.0,
            free=False,
        ),
    )

    def describe(self, r: Reading) -> str:
        """What the data moved: the gas force's coupling to the oil temperature, viscosity and
        damping falling per K, the oil's lead on the measured body."""
        parts = []
        if r.moved("gas_coupling"):
            parts.append(
                "gas force follows the oil temperature (coupling "
                f"{r.v('gas_coupling'):.2g}{r.sd('gas_coupling')})"
            )
        for key in ("viscosity_coeff_per_k", "damping_coeff_per_k"):
            if r.moved(key):
                what = "viscosity" if key.startswith("visc") else "damping"
                parts.append(f"{what} falls {100 * r.v(key):.2g}{r.sd(key, 100)} %/K")
        if parts and r.moved("oil_lead_s"):
            parts.append(
                f"the oil ahead of the measured body by {r.v('oil_lead_s'):.3g}"
                f"{r.sd('oil_lead_s')} s × its rate of rise"
            )
        return "temperature: " + (", ".join(parts) or "the force drifts with the oil temperature")

    def implausible(self, p: Mapping[str, float], spec: DamperSpec) -> str:
        """Refuses values with which the damping rises as the oil warms (by more than 0.5 %/K)."""
        # Oil thins as it warms, and a thinner oil damps less through every path. The
        # term thins the laminar land and leak at b per K and scales all of Δp by
        # exp(-d ΔT): whatever the laminar share, the damping falls while d ≥ -b, and
        # with d below -b it rises everywhere, which no oil does. Seen: a reference-plant
        # 60 N seal with no heat effect fitted d = -4.95 %/K beside b = 2.6 %/K (the
        # channel as a per-test gain); a real heat effect beside air and friction fitted
        # d = -1.7 %/K beside b = 4.2 %/K. Half a percent per kelvin is the noise allowed.
        d, b = p["damping_coeff_per_k"], p["viscosity_coeff_per_k"]
        if d + b < -DAMPING_RISE_PER_K:
            return (
                f"damping rises {-100 * (d + b):.2g} %/K as the oil warms (Δp {-100 * d:+.2g} "
                f"%/K against the viscosity's {-100 * b:.2g} %/K): oil thins as it warms"
            )
        return ""

    def full_rate(self, p: Mapping[str, float], free: Iterable[str]) -> bool:
        """Never: the thermal lag is minutes, which the fit's samples resolve."""
        return False  # minutes of thermal lag: the fit's 5 ms samples resolve it

    def nesting_free(self) -> tuple[str, ...]:
        """The gas coupling, the viscosity and damping coefficients and the oil's lead."""
        return ("gas_coupling", "viscosity_coeff_per_k", "damping_coeff_per_k", "oil_lead_s")

    def vehicle_values(self) -> dict[str, float]:
        """The heating off (`heat_rate_k_s_m2` = 0) for the damper on a car."""
        # No heating on the car: a ride run is seconds, the oil's warm-up minutes.
        return {"heat_rate_k_s_m2": 0.0}

    def temperature(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None
    ) -> tuple[FloatArray, FloatArray | None]:
        """The oil's temperature per sample (°C) and the heating lag's state: the body's channel
        plus `oil_lead_s` × its rate of rise where the channel reads, else the reference plus the
        energy balance's rise (from rest at each test)."""
        ref = p["reference_c"]
        tau = p["cooling_time_s"]
        # The rise starts at nothing (the oil at T_ref), not at the first sample's
        # steady state: a test that starts at speed would otherwise start 80 K hot.
        rise, state = first_order_lag(
            p["heat_rate_k_s_m2"] * tau * w.v**2, tau, w.starts, w.dt_s, carry, from_rest=True
        )
        temp = ref + rise
        channel = w.inputs.channel_temperature
        if channel is not None:
            # The channel is the body's; the oil that heats it is ahead of it by
            # C_body/G(oil→body) × its rate of rise (the body's heat balance).
            body, rise_c_s = channel
            known = np.isfinite(body)
            temp = np.where(known, body + p["oil_lead_s"] * rise_c_s, temp)
        return temp, state

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        """At CHAMBER + 5, thin the leak, the bleed's land and the stacks' seat land by the
        viscosity's fall, scale the gas pressure to the oil's temperature and report it
        (`thermal.temperature_c`), returning the heating state; at PRESSURE - 5, scale Δp by
        exp(-d ΔT)."""
        if stage != self.stage:
            d = p["damping_coeff_per_k"]
            if d:
                assert w.dp is not None
                rise = w.outputs[f"{self.name}.temperature_c"] - p["reference_c"]
                scale = np.exp(-d * rise)
                w.set_dp(self.name, w.dp * scale)
                # A chamber term integrates the flow law itself: the same drop per flow.
                w.dp_scale = w.dp_scale * scale if w.dp_scale.size == scale.size else scale
            return None
        temp, state = self.temperature(w, p, carry)
        ref = p["reference_c"]
        thinning = np.exp(p["viscosity_coeff_per_k"] * (temp - ref))  # ν_ref / ν(T)
        w.k_leak = w.k_leak * thinning
        if w.bleed_laminar.size:
            w.bleed_laminar = w.bleed_laminar / thinning  # the land's resistance ∝ ν
        if w.valve_laminar.size:
            w.valve_laminar = w.valve_laminar / thinning  # so is the stacks' seat land's
        ratio = 1.0 + p["gas_coupling"] * ((temp + KELVIN) / (ref + KELVIN) - 1.0)
        w.set_p_c(self.name, w.p_c * ratio)
        w.outputs[f"{self.name}.temperature_c"] = temp
        return state
