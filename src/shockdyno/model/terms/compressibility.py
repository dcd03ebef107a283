"""Oil compressibility with entrained air: the pressure drop lags the valve's static one.

Wood's mixture law at the chamber's gas charge p (absolute):
    1/β_eff = (1 - α) c_oil + α / p
and the chamber of volume V (piston area × the spec's oil column) behind a valve of
conductance G = ∂q/∂Δp fills with the time constant τ = V / (β_eff G), so
    τ dΔp/dt = Δp_static - Δp.
Off: α = 0 and c_oil = 0 (rigid oil: τ = 0). τ is per test, at its gas charge, so a test
at another gas pressure sees another τ: that is how the data separate air from a sensor
lag. Only τ is identifiable from one charge; the fit frees α and holds c_oil and G.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from shockdyno.model.composite import PRESSURE, Evaluation, FloatArray, Term, Work
from shockdyno.model.filters import first_order_lag
from shockdyno.model.params import Param
from shockdyno.model.spec import DamperSpec

MAX_BULK_MODULUS_PA = 2.2e9


class Compressibility(Term):
    name = "compressibility"
    stage = PRESSURE
    stateful = True
    summary = "oil bulk modulus with entrained air: Δp lags, the loop opens near reversal"
    PARAMS = (
        Param("air_fraction", "1", 0.01, 0.0, 0.3, 0.01, 0.0, doc="free air by volume"),
        Param(
            "oil_compressibility_per_gpa",
            "1/GPa",
            1 / 1.5,
            0.0,
            2.0,
            0.5,
            0.0,
            free=False,
            doc="1/β of the oil (mineral oil: 1/1.5 GPa)",
        ),
        Param(
            "valve_conductance_m3_s_pa",
            "m³/(s·Pa)",
            2.0e-11,
            1.0e-13,
            1.0e-8,
            1.0e-11,
            2.0e-11,
            free=False,
            doc="∂q/∂Δp of the piston near its operating point",
        ),
    )

    def nesting_free(self) -> tuple[str, ...]:
        # The oil alone lags (β = 1.5 GPa): only with its compressibility free too can the
        # term fall back to the paper's rigid oil.
        return ("air_fraction", "oil_compressibility_per_gpa")

    def implausible(self, p: Mapping[str, float], spec: DamperSpec) -> str:
        # Mineral oil is 1.5-2 GPa; oil with any air is softer. A fit that needs stiffer
        # oil is using a tiny lag to stand in for something else (a sensor): a 2 ms
        # load-cell lag fitted as 0.03 % air in 5 GPa oil, 2.46 GPa in all, which the
        # earlier 2.5 GPa limit let through. 2.2 GPa leaves 10 % over the stiffest oil.
        comp = (1 - p["air_fraction"]) * p["oil_compressibility_per_gpa"] * 1e-9
        comp += p["air_fraction"] / spec.gas_pressure_pa
        if comp > 0 and 1 / comp > MAX_BULK_MODULUS_PA:
            return f"effective bulk modulus {1e-9 / comp:.3g} GPa: stiffer than any oil"
        return ""

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        return [{"air_fraction": a} for a in (0.001, 0.01, 0.05)]

    def time_constants(self, w: Work, p: Mapping[str, float]) -> FloatArray:
        """τ per segment (s), at each segment's gas charge."""
        spec = w.spec
        charge = np.full(w.starts.size, spec.gas_pressure_pa)
        gp = w.inputs.gas_pressure_pa
        if gp is not None:
            finite = np.isfinite(gp)
            if np.any(finite):
                charge = np.where(finite, spec.gas_pressure_pa * gp / np.mean(gp[finite]), charge)
        alpha = p["air_fraction"]
        compliance = (1 - alpha) * p["oil_compressibility_per_gpa"] * 1e-9 + alpha / charge
        volume = spec.piston_area_m2 * spec.oil_column_m
        return np.asarray(volume * compliance / p["valve_conductance_m3_s_pa"], dtype=float)

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        assert w.dp is not None
        tau = self.time_constants(w, p)
        dp, state = first_order_lag(w.dp, tau, w.starts, w.dt_s, carry, periodic=w.inputs.periodic)
        w.set_dp(self.name, dp)
        w.outputs[f"{self.name}.time_constant_s"] = tau[w.inputs.segment_of_sample()]
        return state
