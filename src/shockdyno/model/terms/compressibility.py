"""Oil compressibility with entrained air: the rebound chamber's pressure is a state.

The chamber (model/chamber.py) fills through the piston's own flow law against its
compliance, Wood's law at the local absolute pressure p:

    C(p) = α V₀ p₀ / p² + (V(x) - α V₀) c_oil,     V(x) = A_r (L + x),  V₀ = A_r L,

α the free air by volume at the charge pressure p₀ (the spec's gas pressure) in the
chamber's mid-stroke volume (a fixed amount of air), c_oil the oil's compressibility
(with what gives with it: a constant effective bulk modulus is c_oil alone). The
pressure drop lags its static value most where the chamber's pressure is lowest (on the
compression stroke, where air expands), and the loop opens near reversal. Off: α = 0
and c_oil = 0 (rigid oil: the algebraic solve, exactly). The fit frees α and holds c_oil
(name it to free it: `compressibility.oil_compressibility_per_gpa`); the diagnosis frees
both, so either form (air, or a constant effective modulus) can be found.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from shockdyno.model.chamber import Chamber, integrate
from shockdyno.model.composite import PRESSURE, Evaluation, FloatArray, Term, Work
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading
from shockdyno.model.spec import DamperSpec

MAX_BULK_MODULUS_PA = 2.2e9


def run_chamber(
    w: Work, chamber: Chamber, carry: FloatArray | None
) -> tuple[FloatArray, FloatArray, FloatArray | None, FloatArray, FloatArray]:
    """(Δp, vapour volume, state, p_c, released gas's volume) of the chamber on the work's
    samples, from the static
    Δp and p_c the flow solve gave (kept in w.dp_static and w.p_c_static for the next
    chamber term); the compression chamber's pressure follows what the chamber's
    contents took from the gas side (w.set_p_c, the term's own part)."""
    if w.dp_static is None:
        w.dp_static = w.dp
    if w.p_c_static is None:
        w.p_c_static = w.p_c
    assert w.dp_static is not None and w.p_c_static is not None
    if chamber.inert:
        none = np.zeros_like(w.dp_static)
        return w.dp_static, none, None, w.p_c_static, none
    dp, vapour, p_c, state, gas = integrate(
        w.spec,
        chamber,
        w.x,
        w.v,
        w.p_c_static,
        w.dp_static,
        w.bleed_compression_m2,
        w.bleed_rebound_m2,
        w.k_leak,
        w.starts,
        w.dt_s,
        w.inputs.periodic,
        carry,
        w.bleed_laminar if w.bleed_laminar.size == w.x.size else None,
        w.gas_volume if w.gas_volume.size == w.x.size else None,
        w.gas_index,
        w.dp_scale if w.dp_scale.size == w.x.size else None,
        w.valve_laminar if w.valve_laminar.size == w.x.size else None,
    )
    return dp, vapour, state, p_c, gas


def bulk_modulus_pa(p: Mapping[str, float], pressure_pa: float, charge_pa: float) -> float:
    """β_eff of the chamber's oil at an absolute pressure (Wood's law); inf for rigid oil."""
    alpha = p["air_fraction"]
    comp = (1 - alpha) * p["oil_compressibility_per_gpa"] * 1e-9
    comp += alpha * charge_pa / pressure_pa**2
    return 1 / comp if comp > 0 else math.inf


class Compressibility(Term):
    """Entrained air and oil compliance: the rebound chamber's pressure integrated as a state
    through the piston's flow law (Wood's law), so Δp lags its static value."""

    name = "compressibility"
    stage = PRESSURE
    stateful = True
    summary = "oil bulk modulus with entrained air: Δp lags, the loop opens near reversal"
    follows = ("lag",)
    separated_by: ClassVar[dict[str, str]] = {
        "friction": "tests at other frequencies and gas pressures"
    }
    PARAMS = (
        Param(
            "air_fraction",
            "1",
            nominal=0.01,
            lo=0.0,
            hi=0.3,
            scale=0.01,
            off=0.0,
            doc="free air by volume at p₀",
        ),
        Param(
            "oil_compressibility_per_gpa",
            "1/GPa",
            nominal=1 / 1.5,
            lo=0.0,
            # To 1/(50 MPa): what gives with the oil (a tube's swell, seals, gas held in
            # solution that a model of free air does not describe) is a compliance of the
            # same form; mineral oil alone is 1/1.5-1/2 GPa.
            hi=20.0,
            scale=0.5,
            off=0.0,
            free=False,
            doc="1/β of the oil and what gives with it (mineral oil: 1/1.5 GPa)",
        ),
    )

    def describe(self, r: Reading) -> str:
        """The effective bulk modulus at the gas charge (MPa), and the free air (% by volume)
        when the data moved it."""
        alpha = r.v("air_fraction")
        c_oil = r.v("oil_compressibility_per_gpa") * 1e-9
        comp = (1 - alpha) * c_oil + alpha / r.spec_gas_pa
        beta = 1 / comp if comp > 0 else math.inf
        head = f"compressibility: effective bulk modulus {beta / 1e6:.3g} MPa at the gas charge"
        # One reading of one term: free air only when the data moved it, else the modulus
        # is the oil's (and what gives with it) alone, and a "0 % air" beside it would be a
        # second reading that disagrees with the first.
        if not r.moved("air_fraction"):
            return f"{head}, as a stiffness of the oil itself (no free air resolved)"
        sd = r.sd_value("air_fraction")
        pm = f" ± {100 * sd:.1g}" if math.isfinite(sd) else ""
        return f"{head}, about {100 * alpha:.2g}{pm} % free air"

    def nesting_free(self) -> tuple[str, ...]:
        """Both the air fraction and the oil's compressibility: only with both free can the term
        reach the paper's rigid oil."""
        # The oil alone lags (β = 1.5 GPa): only with its compressibility free too can the
        # term fall back to the paper's rigid oil.
        return ("air_fraction", "oil_compressibility_per_gpa")

    def implausible(self, p: Mapping[str, float], spec: DamperSpec) -> str:
        """Refuses an effective bulk modulus at the charge pressure stiffer than any oil (2.2
        GPa)."""
        # Mineral oil is 1.5-2 GPa; oil with any air is softer. A fit that needs stiffer
        # oil at the charge pressure is using a tiny lag to stand in for something else
        # (a sensor's lag). 2.2 GPa leaves 10 % over the stiffest oil.
        beta = bulk_modulus_pa(p, spec.gas_pressure_pa, spec.gas_pressure_pa)
        if math.isfinite(beta) and beta > MAX_BULK_MODULUS_PA:
            return f"effective bulk modulus {beta / 1e9:.3g} GPa: stiffer than any oil"
        return ""

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        """Starts at 0.1 %, 1 % and 5 % free air."""
        return [{"air_fraction": a} for a in (0.001, 0.01, 0.05)]

    def chamber(self, w: Work, p: Mapping[str, float]) -> Chamber:
        """The chamber this term's values describe: air fraction at the spec's gas charge, the
        oil's compressibility per Pa, no vapour floor, the spec's oil column."""
        return Chamber(
            air_fraction=p["air_fraction"],
            charge_pa=w.spec.gas_pressure_pa,
            oil_compressibility_per_pa=p["oil_compressibility_per_gpa"] * 1e-9,
            release_pa=-math.inf,
            length_m=w.spec.oil_column_m,
        )

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        """Integrate the rebound chamber (PRESSURE stage): replaces Δp and p_c with the
        integrated ones (the change is this term's force part), reports the bulk modulus per
        sample (`compressibility.bulk_modulus_pa`), and returns the chamber's state to carry."""
        assert w.dp is not None
        chamber = self.chamber(w, p)
        w.chamber = chamber
        dp, _, state, p_c, _ = run_chamber(w, chamber, carry)
        w.set_p_c(self.name, p_c)
        w.set_dp(self.name, dp)
        p_r = w.p_c - dp
        w.outputs[f"{self.name}.bulk_modulus_pa"] = np.asarray(
            1.0
            / np.maximum(
                (1 - p["air_fraction"]) * p["oil_compressibility_per_gpa"] * 1e-9
                + p["air_fraction"] * w.spec.gas_pressure_pa / np.maximum(p_r, 1.0) ** 2,
                1e-30,
            ),
            dtype=float,
        )
        return state
