"""A reference damper plant whose equations are not the fitting library's.

The diagnosis fits the term library (`model/terms/`, with the paper's flow law, shim stack
and bleed map); a rig that evaluated those equations, or re-typed them, would test the
search against itself. This plant takes from the model package only the damper's
description (`DamperSpec`: its geometry numbers, never its derived laws: not
`bleed_areas`, not the shim stack's stiffness or preload force) and writes every effect in
a form of its own. docs/diagnose-method.md has the table, form by form, plant against library.

Chambers. Both hold a fixed mass of oil that moves through the piston (mass, not volume,
is what passes: each chamber takes it at its own density). The oil is a Tait liquid,
v = v₀ (1 - C ln(1 + (p - p_atm)/B)), B = C K₀ (its tangent modulus K₀ at 1 atm rises
with pressure by 1/C ≈ 11 per Pa), with free air mixed in it and carried with it (a fixed
mass of air per kg of oil, polytropic with the bubbles' own index), so each chamber's air
is that of the oil it holds, at its own pressure and volume. The floating piston is
massless and frictionless; the gas behind it is an ideal gas with a temperature of its
own, compressed adiabatically and relaxing to the wall over a thermal time (a gas spring
between isothermal and adiabatic, with the small loop that leaves).

Cavities. The rebound chamber holds a population of bubble nuclei. Below the release
pressure p_v their walls move out at Rayleigh's speed, Ṙ = √(2 (p_v - p)/(3ρ)), and back in
above it, so the cavity volume grows at N 4πR² Ṙ: nothing forms above p_v, and a stroke
that outruns the flow pulls the chamber a little under it while the bubbles grow. Air
comes out of solution through the cavities' walls while they stand (a desorption speed),
and stays as free gas after they collapse, going back into solution over a time that
shortens as the pressure rises.

Piston flow, Δp = p_k - p_r. Each path is a slit-like passage whose discharge coefficient
follows its flow number, C_d = C_d∞ tanh(2λ/λ_c) with λ = (D_h/ν) √(2Δp/ρ) (Borutzky,
Barnard & Thoma 2002), λ_c set so that the laminar limit is the slit's Poiseuille flow:
- the bleeds: the annulus between a tapered needle and its seat. The adjuster turns the
  needle on a 0.5 mm thread, 4 clicks a turn (assumed); the annulus normal to the cone is
  π h sin α (d - h sin α cos α) at lift h, smoothly capped at the seat's bore
  (A = A_f A_s / (A_f⁴ + A_s⁴)^¼), the seat's bore being the spec's open bleed area
  (`area_open_m2`: ≈ 3.9 mm compression, 2.3 mm rebound), the cone's half angle 45°
  compression, 15° rebound (assumed), its land 1 mm (`needle_land_m`). The gas selector
  opens a parallel jet of the spec's area per gas click.
- the shim stacks: each a wedge beam (the shims as radial strips of width 2πr, clamped at
  the clamp radius, loaded at the outer edge, plate modulus E/(1 - ν²)), pre-bent by the
  spec's dish, stiffening as it bends (F = k₀ s (1 + c (s/t)²)), stopped by a backing shim
  past the spec's max lift; its lift follows the lift the pressure holds with an opening
  time and a (longer) closing time. The slit under it has the seat's perimeter and a
  0.3 mm land (`valve_land_m`).
- the piston band: laminar flow through an eccentric annular gap (eccentricity 0.5:
  (1 + 1.5 ε²) the concentric gap's flow); the oil the band drags is left out (0.1 % of
  the swept flow).
Viscosity: the spec's 11 cSt held, or (`viscosity_at_100c_cst` > 0) Walther's ASTM D341
line through the spec's 40 °C value and the 100 °C one: it acts on every passage's
laminar share, the band's leak and the seal lip's drag.

Rod seal: elasto-plastic (Dupont et al. 2002): a deflection z that is purely elastic up to
a share of its steady value, then slides, dz/dx = 1 - α(z) z/z_ss, z_ss = g(v)/σ₀ with the
Hess-Soom level g(v) = F_c + F_b/(1 + (v/v_s)²) (F_c the spec's friction), plus a lip's
hydrodynamic drag ∝ (μ v)^0.4. Bump stop: an elastomer with an exponential backbone and a
Maxwell branch in parallel (rate-dependent: loading above unloading), pushing only.
Heat: oil ← the piston's dissipation, body ← the seal's, oil → body, body → ambient by
natural convection (∝ ΔT^1.25). Sensors: the load cell's own mechanical resonance
(second order), then a 4-pole Bessel anti-alias filter on both channels, and the force
channel sampled `force_skew_s` after the position. The temperature channel is the body's.

Integration: 8 implicit sub-steps a 1 kHz sample (reference_kernel.py, compiled),
each solving both chambers' volume balances for the rebound pressure and the gas
piston's travel.

Defaults are a clean damper close to the paper's: oil as stiff as the paper assumes
(K₀ 100 GPa), no air, release at 3 kPa, no breakaway beyond Coulomb, no lip drag,
viscosity held, the gas's wall at its fill temperature, no bump stop, no skew.
Scenario files select it with `[plant] kind = "reference"` (docs/scenarios.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any

import numpy as np
from msgspec import Meta
from numpy.typing import NDArray

from shockdyno.errors import ConfigError
from shockdyno.model.spec import DamperSpec
from shockdyno.record.types import TestData, TestMeta
from shockdyno.schema import Fraction, NonNegative, Positive, convert
from shockdyno.simrig import reference_kernel as kern

FloatArray = NDArray[np.float64]
P_ATM = kern.P_ATM
KELVIN = kern.KELVIN
SUB_RATE_HZ = 8000.0  # implicit steps a second (8 a sample at 1 kHz)
# The adjusters (assumptions: the spec gives areas, not needles).
THREAD_PITCH_M = 0.5e-3
CLICKS_PER_TURN = 4
NEEDLE_HALF_ANGLE_DEG = (45.0, 15.0)  # compression, rebound
SEAT_CAP_ORDER = 4.0
BACKING_STOP = 30.0  # the backing shim's stiffness, × the stack's
LEAK_ECCENTRICITY = 0.5
LIP_REF_SPEED_M_S = 0.1


@dataclass(frozen=True)
class PlantParams:
    """A scenario's [plant] table (read through shockdyno.schema: the types are the checks)."""

    # oil: a Tait liquid with entrained air carried in it
    oil_bulk_modulus_pa: Positive = 1.0e11  # K₀ at 1 atm; mineral oil 1.6e9
    air_fraction: Annotated[float, Meta(ge=0, lt=0.5)] = 0.0  # free air by volume at the charge
    air_polytropic_index: Annotated[float, Meta(ge=1, le=1.4)] = 1.0
    # cavities in the rebound chamber
    release_pressure_pa: NonNegative = 3.0e3  # the cavities' inside: vapour + released air
    nuclei_per_cm3: NonNegative = 200.0
    nucleus_radius_m: Positive = 20e-6
    gas_desorption_m_s: NonNegative = 1.0e-4  # air (at 1 atm) out per m² of cavity wall, per s
    gas_resorption_time_s: Positive = 1.0  # at the charge; shorter at higher pressure
    # flow paths
    needle_land_m: Positive = 0.001  # the needle annulus's laminar length
    valve_land_m: Positive = 3.0e-4  # the seat land under a shim stack's edge
    discharge_coefficient: Positive = 0.7  # C_d∞ of every passage
    valve_open_time_s: Positive = 3.0e-4
    valve_close_time_s: Positive = 1.0e-3
    valve_progression: NonNegative = 0.1  # c in F = k₀ s (1 + c (s/t)²)
    # gas
    gas_pressure_factor: Positive = 1.0  # × the spec's charge
    gas_volume_factor: Positive = 1.0  # × the spec's gas volume
    gas_heat_capacity_ratio: Annotated[float, Meta(ge=1, le=1.67)] = 1.4
    gas_thermal_time_s: Positive = 0.02
    gas_thermal_coupling: NonNegative = 0.0  # share of the body's warming the gas's wall sees
    # rod seal: elasto-plastic, Hess-Soom level, lip drag
    breakaway_n: NonNegative = 0.0  # static less sliding (F_s - F_c)
    stribeck_velocity_m_s: Positive = 0.005
    seal_presliding_m: Positive = 10e-6  # steady deflection at the Coulomb level
    seal_elastic_share: Fraction = 0.6  # purely elastic up to this share of it
    lip_drag_n: NonNegative = 0.0  # at 0.1 m/s and 40 °C; ∝ (μ v)^0.4
    # heat
    viscosity_at_100c_cst: NonNegative = 0.0  # 0: the spec's viscosity held
    oil_heat_capacity_j_k: Positive = 300.0
    body_heat_capacity_j_k: Positive = 900.0
    oil_to_body_w_k: NonNegative = 6.0
    body_convection_w_k125: NonNegative = 1.0  # W / K^1.25
    heating_factor: NonNegative = 1.0  # × the dissipated power that reaches the oil
    start_temperature_c: Annotated[float, Meta(ge=-273.15)] = math.nan  # NaN: the rig's ambient
    # bump stop
    bump_onset_m: NonNegative = math.inf
    bump_force_at_10mm_n: NonNegative = 0.0  # the backbone's force 10 mm past the onset
    bump_length_m: Positive = 0.006  # the backbone's e-folding compression
    bump_loss_share: NonNegative = 0.3  # the Maxwell branch's stiffness, × F_10 / 10 mm
    bump_relaxation_time_s: Positive = 0.05
    # sensors
    anti_alias_hz: Positive = 300.0  # 4-pole Bessel, -3 dB
    load_cell_hz: Positive = 1500.0
    load_cell_damping: Positive = 0.05
    force_skew_s: NonNegative = 0.0

    @staticmethod
    def from_table(table: dict[str, Any], source: str, at: str = "plant") -> PlantParams:  # TOML
        return convert({k: v for k, v in table.items() if k != "kind"}, PlantParams, source, at)


@dataclass
class PlantState:
    s: FloatArray  # the kernel's state (reference_kernel.S)
    ring: FloatArray  # the force channel's recent filtered sub-samples
    t_s: float
    x_m: float
    v_m_s: float
    a_m_s2: float


def needle_area(clicks: float, seat_m: float, half_angle_deg: float) -> float:
    """Flow area of a tapered needle `clicks` out of its seat: the cone's annulus normal to
    its surface, smoothly capped at the seat's bore."""
    h = clicks * THREAD_PITCH_M / CLICKS_PER_TURN
    if h <= 0.0:
        return 0.0
    sa, ca = math.sin(math.radians(half_angle_deg)), math.cos(math.radians(half_angle_deg))
    across = max(seat_m - h * sa * ca, 0.0)
    cone = math.pi * h * sa * across
    bore = math.pi / 4 * seat_m**2
    if cone <= 0.0:
        return bore
    return float(
        cone * bore / (cone**SEAT_CAP_ORDER + bore**SEAT_CAP_ORDER) ** (1 / SEAT_CAP_ORDER)
    )


def wedge_beam_stiffness(
    n: int, thick: float, outer_m: float, clamp_m: float, e_pa: float, nu: float
) -> float:
    """A shim stack's edge stiffness as radial strips of width 2πr (no hoop stress),
    clamped at the clamp radius b and loaded at the outer radius a (unit-load method):
    k = n π E' t³ / (6 [a² ln(a/b) - 2a(a - b) + (a² - b²)/2]), E' = E/(1 - ν²)."""
    a, b = outer_m / 2, clamp_m / 2
    span = a * a * math.log(a / b) - 2 * a * (a - b) + (a * a - b * b) / 2
    return n * math.pi * e_pa / (1 - nu * nu) * thick**3 / (6 * span)


def _walther(nu40_cst: float, nu100_cst: float) -> tuple[float, float]:
    """(A, B) of log10 log10(ν + 0.7) = A - B log10 T through (40 °C, ν40), (100 °C, ν100)."""
    t1, t2 = math.log10(40 + KELVIN), math.log10(100 + KELVIN)
    y1 = math.log10(math.log10(nu40_cst + 0.7))
    y2 = math.log10(math.log10(nu100_cst + 0.7))
    b = (y1 - y2) / (t2 - t1)
    return y1 + b * t1, b


def _chamber_constants(k: FloatArray, s: DamperSpec, p: PlantParams, p0: float) -> None:
    """The kernel's geometry, oil (Tait liquid with its entrained air), gas and cavities."""
    K = kern.K
    a_p, a_rod = math.pi / 4 * s.piston_diameter_m**2, math.pi / 4 * s.rod_diameter_m**2
    a_g = math.pi / 4 * s.gas_piston_diameter_m**2
    k[K["A_P"]], k[K["A_A"]], k[K["A_ROD"]], k[K["A_G"]] = a_p, a_p - a_rod, a_rod, a_g
    k[K["L_COL"]] = s.oil_column_m
    k[K["M_ROD"]] = s.piston_rod_mass_kg
    rho = s.oil_density_kg_m3
    k[K["RHO"]], k[K["V0"]] = rho, 1.0 / rho
    k[K["TAIT_B"]] = kern.TAIT_C * p.oil_bulk_modulus_pa
    k[K["P0"]] = p0
    k[K["KAPPA"]] = p.air_polytropic_index
    k[K["W_AIR"]] = 0.0
    # air per kg of oil: α of the mixture's volume at the charge
    v_liq0 = kern.specific_volume(k, p0)
    k[K["W_AIR"]] = p.air_fraction / (1.0 - p.air_fraction) * v_liq0
    k[K["VG0"]] = a_g * s.gas_length_m * p.gas_volume_factor
    k[K["GAMMA"]], k[K["TAU_G"]] = p.gas_heat_capacity_ratio, p.gas_thermal_time_s
    k[K["COUPLING"]] = p.gas_thermal_coupling
    k[K["P_V"]] = p.release_pressure_pa
    n_b = p.nuclei_per_cm3 * 1e6 * (a_p - a_rod) * s.oil_column_m
    k[K["N_B"]] = n_b
    k[K["V_N"]] = n_b * 4 / 3 * math.pi * p.nucleus_radius_m**3
    k[K["C_NUC"]] = (36 * math.pi * n_b) ** (1 / 3)
    k[K["U_DES"]], k[K["TAU_RES"]] = p.gas_desorption_m_s, p.gas_resorption_time_s


def _flow_constants(k: FloatArray, s: DamperSpec, p: PlantParams) -> None:
    """The kernel's flow paths: passages, the piston's leak and each shim stack."""
    K = kern.K
    k[K["CD"]] = p.discharge_coefficient
    k[K["NEEDLE_LAND"]], k[K["VALVE_LAND"]] = p.needle_land_m, p.valve_land_m
    k[K["TAU_OPEN"]], k[K["TAU_CLOSE"]] = p.valve_open_time_s, p.valve_close_time_s
    k[K["LEAK_G"]] = (
        math.pi
        * s.piston_diameter_m
        * s.leak_gap_m**3
        * (1 + 1.5 * LEAK_ECCENTRICITY**2)
        / (12 * s.leak_land_length_m)
    )
    for tag, v in (("C", s.compression_valve), ("R", s.rebound_valve)):
        k[K[f"K0_{tag}"]] = wedge_beam_stiffness(
            v.n_shims,
            v.thickness_m,
            v.outer_diameter_m,
            v.clamp_diameter_m,
            v.youngs_modulus_pa,
            v.poisson,
        )
        k[K[f"DISH_{tag}"]], k[K[f"T_{tag}"]] = v.preload_m, v.thickness_m
        k[K[f"YMAX_{tag}"]], k[K[f"FACE_{tag}"]] = v.max_lift_m, v.face_area_m2
        k[K[f"PERIM_{tag}"]] = math.pi * v.seat_diameter_m
    k[K["PROG"]], k[K["STOP"]] = p.valve_progression, BACKING_STOP


def _seal_bump_heat_constants(k: FloatArray, s: DamperSpec, p: PlantParams) -> None:
    """The kernel's viscosity law, rod seal, bump stop and heat balance."""
    K = kern.K
    k[K["MU40"]] = s.oil_viscosity_cst * 1e-6 * s.oil_density_kg_m3
    if p.viscosity_at_100c_cst > 0:
        if p.viscosity_at_100c_cst >= s.oil_viscosity_cst:
            raise ConfigError(
                "plant.viscosity_at_100c_cst: must be below the spec's 40 °C viscosity "
                f"({s.oil_viscosity_cst:g} cSt), got {p.viscosity_at_100c_cst:g}"
            )
        k[K["WALTHER"]] = 1.0
        k[K["WA"]], k[K["WB"]] = _walther(s.oil_viscosity_cst, p.viscosity_at_100c_cst)
    k[K["FC"]], k[K["FB"]], k[K["VS"]] = s.friction_n, p.breakaway_n, p.stribeck_velocity_m_s
    k[K["SIG0"]] = max(s.friction_n, 1.0) / p.seal_presliding_m
    k[K["ZBA"]], k[K["LIP"]] = p.seal_elastic_share, p.lip_drag_n
    k[K["XB"]], k[K["F10"]], k[K["LB"]] = (
        p.bump_onset_m,
        p.bump_force_at_10mm_n,
        p.bump_length_m,
    )
    k[K["KM"]] = p.bump_loss_share * p.bump_force_at_10mm_n / 0.010
    k[K["TAU_M"]] = p.bump_relaxation_time_s
    k[K["C_O"]], k[K["C_B"]] = p.oil_heat_capacity_j_k, p.body_heat_capacity_j_k
    k[K["G_OB"]], k[K["H_CONV"]] = p.oil_to_body_w_k, p.body_convection_w_k125
    k[K["HEAT"]] = p.heating_factor


def _sensor_constants(k: FloatArray, p: PlantParams, fs_sub: float) -> int:
    """The kernel's load cell resonance, anti-alias filter and force skew, at the
    sub-sample rate; the length of the force channel's ring of recent sub-samples."""
    # here: scipy.signal would add 840 ms CPU to every command's start-up (measured)
    from scipy import signal

    wn = 2 * math.pi * p.load_cell_hz
    warped = 2 * fs_sub * math.tan(wn / (2 * fs_sub))  # the resonance where it is
    b, a = signal.bilinear(
        [warped**2], [1.0, 2 * p.load_cell_damping * warped, warped**2], fs=fs_sub
    )
    _set_sos(k, "LC", signal.tf2sos(b, a)[0])
    f_aa = min(p.anti_alias_hz, 0.45 * fs_sub)
    aa = signal.bessel(4, f_aa, norm="mag", fs=fs_sub, output="sos")
    _set_sos(k, "AA0", aa[0])
    _set_sos(k, "AA1", aa[1])
    k[kern.K["SKEW"]] = p.force_skew_s * fs_sub
    return math.ceil(p.force_skew_s * fs_sub) + 3


def _set_sos(k: FloatArray, tag: str, sec: FloatArray) -> None:
    sec = np.asarray(sec, float) / float(sec[3])
    base = kern.K[f"{tag}_B0"]
    k[base : base + 3] = sec[:3]
    k[base + 3 : base + 5] = sec[4:6]


class ReferencePlant:
    """The plant: `run` gives a chunk of samples, carrying its state explicitly."""

    def __init__(self, spec: DamperSpec, params: PlantParams, fs_hz: float) -> None:
        self.spec = spec
        self.p = params
        self.fs = fs_hz
        self.m = max(1, round(SUB_RATE_HZ / fs_hz))
        k = np.zeros(kern.NK)
        k[kern.K["H"]] = 1.0 / (fs_hz * self.m)
        self.p0 = spec.gas_pressure_pa * params.gas_pressure_factor
        _chamber_constants(k, spec, params, self.p0)
        _flow_constants(k, spec, params)
        _seal_bump_heat_constants(k, spec, params)
        self.ring_size = _sensor_constants(k, params, fs_hz * self.m)
        self.k = k
        self.fixed = self._gap_table()
        # compile (or load the cache) now, not in the middle of a sweep's first batch
        self.run(
            np.array([0.0]),
            np.zeros(1),
            np.zeros(1),
            np.zeros(1),
            (0, 0),
            self.initial(0.0, 40.0),
            40.0,
        )

    def _gap_table(self) -> dict[str, float]:
        s = self.spec
        return {
            "seat_c": math.sqrt(4 * s.compression_bleed.area_open_m2 / math.pi),
            "seat_r": math.sqrt(4 * s.rebound_bleed.area_open_m2 / math.pi),
        }

    # -- the adjusters --------------------------------------------------------------------
    def paths(self, clicks: int, gas_clicks: int, ambient_c: float) -> FloatArray:
        """The kernel's per-run array: each needle's area and slit gap at these clicks, the
        gas selector's jet, the ambient temperature."""
        s = self.spec
        top = s.compression_bleed.max_clicks
        if not 0 <= clicks <= top:
            raise ConfigError(f"rod clicks must be 0-{top}, got {clicks}")
        if not 0 <= gas_clicks <= s.max_gas_clicks:
            raise ConfigError(f"gas-bottle clicks must be 0-{s.max_gas_clicks}, got {gas_clicks}")
        f = np.zeros(kern.NF)
        for i, (seat, law, angle) in enumerate(
            (
                (self.fixed["seat_c"], s.compression_bleed, NEEDLE_HALF_ANGLE_DEG[0]),
                (self.fixed["seat_r"], s.rebound_bleed, NEEDLE_HALF_ANGLE_DEG[1]),
            )
        ):
            area = law.area_closed_m2 + needle_area(clicks, seat, angle)
            f[2 * i] = area
            f[2 * i + 1] = area / (math.pi * seat)  # the slit of the seat's perimeter
        jet = max(s.rebound_bleed.area_per_gas_click_m2 * gas_clicks, 0.0)
        f[kern.F_AJ] = jet
        f[kern.F_GJ] = math.sqrt(jet / math.pi)  # a round jet: its radius as the gap
        f[kern.F_AMB] = ambient_c
        return f

    # -- chunks -------------------------------------------------------------------------
    def initial(self, x0: float, ambient_c: float) -> PlantState:
        """At rest at x0: filled at mid-stroke at the charge and the start temperature, the
        gas piston where the rod's volume has pushed it."""
        k, S = self.k, kern.S
        t0 = ambient_c if math.isnan(self.p.start_temperature_c) else self.p.start_temperature_c
        k[kern.T_FILL] = t0 + KELVIN
        a_a, a_p, a_g, col = k[kern.A_A], k[kern.A_P], k[kern.A_G], k[kern.L_COL]
        v_fill = kern.specific_volume(k, self.p0)
        m_tot = (a_a + a_p) * col / v_fill
        vg0 = k[kern.VG0]

        def gas_p(y: float) -> float:
            return float(self.p0 * vg0 / (vg0 - a_g * y))

        def excess(y: float) -> float:
            room = a_a * (col + x0) + a_p * (col - x0) + a_g * y
            return float(m_tot * kern.specific_volume(k, gas_p(y)) - room)

        lo, hi = -0.5 * vg0 / a_g, 0.9 * vg0 / a_g
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if excess(mid) > 0:
                lo = mid
            else:
                hi = mid
        y_g = 0.5 * (lo + hi)
        p = gas_p(y_g)
        st = np.zeros(kern.NS)
        st[S["PR"]] = st[S["PK"]] = p
        st[S["YG"]], st[S["TG"]] = y_g, t0 + KELVIN
        st[S["MR"]] = a_a * (col + x0) / kern.specific_volume(k, p)
        st[S["MK"]] = m_tot - st[S["MR"]]
        st[S["TO"]] = st[S["TB"]] = t0
        st[S["X"]] = x0
        f0 = (p - P_ATM) * k[kern.A_ROD]
        st[S["FORCE"]] = f0
        for tag, val in (("LC", f0), ("FAA0", f0), ("FAA1", f0), ("XAA0", x0), ("XAA1", x0)):
            coef = "LC_B0" if tag == "LC" else f"AA{tag[-1]}_B0"
            b0, b1, b2, a1, a2 = k[kern.K[coef] : kern.K[coef] + 5]
            gain = (b0 + b1 + b2) / (1 + a1 + a2)
            out = gain * val
            st[S[f"{tag}_Z1"]] = out - b0 * val
            st[S[f"{tag}_Z2"]] = b2 * val - a2 * out
        return PlantState(
            s=st,
            ring=np.full(self.ring_size, f0),
            t_s=-1.0 / self.fs,
            x_m=x0,
            v_m_s=0.0,
            a_m_s2=0.0,
        )

    def run_detail(
        self,
        t: FloatArray,
        x: FloatArray,
        v: FloatArray,
        a: FloatArray,
        clicks: tuple[int, int],
        state: PlantState,
        ambient_c: float,
    ) -> tuple[FloatArray, PlantState]:
        """The kernel's rows for these samples (reference_kernel.advance: true force,
        sensed force, sensed position, body and oil temperature, rebound pressure, cavity
        volume, released air, the seal's elastic force) and the new state. The motion
        between samples is the cubic through each pair of samples' positions and speeds."""
        n = t.size
        m = self.m
        x0 = np.concatenate([[state.x_m], x[:-1]])
        v0 = np.concatenate([[state.v_m_s], v[:-1]])
        a0 = np.concatenate([[state.a_m_s2], a[:-1]])
        dt = np.diff(np.concatenate([[state.t_s], t]))
        frac = (np.arange(1, m + 1) / m)[None, :]
        s2, s3 = frac * frac, frac * frac * frac
        d = dt[:, None]
        xs = (
            (2 * s3 - 3 * s2 + 1) * x0[:, None]
            + (s3 - 2 * s2 + frac) * d * v0[:, None]
            + (-2 * s3 + 3 * s2) * x[:, None]
            + (s3 - s2) * d * v[:, None]
        )
        vs = (
            (6 * s2 - 6 * frac) * x0[:, None] / d
            + (3 * s2 - 4 * frac + 1) * v0[:, None]
            + (-6 * s2 + 6 * frac) * x[:, None] / d
            + (3 * s2 - 2 * frac) * v[:, None]
        )
        acc = a0[:, None] + frac * (a - a0)[:, None]
        s = state.s.copy()
        ring = state.ring.copy()
        out = np.empty((9, n))
        kern.advance(
            s,
            self.k,
            self.paths(clicks[0], clicks[1], ambient_c),
            ring,
            np.ascontiguousarray(xs.ravel()),
            np.ascontiguousarray(vs.ravel()),
            np.ascontiguousarray(acc.ravel()),
            m,
            out,
        )
        new = PlantState(
            s=s,
            ring=ring,
            t_s=float(t[-1]),
            x_m=float(x[-1]),
            v_m_s=float(v[-1]),
            a_m_s2=float(a[-1]),
        )
        return out, new

    def run(
        self,
        t: FloatArray,
        x: FloatArray,
        v: FloatArray,
        a: FloatArray,
        clicks: tuple[int, int],
        state: PlantState,
        ambient_c: float,
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, PlantState]:
        """(true force, sensed force, sensed position, body temperature, new state)."""
        out, new = self.run_detail(t, x, v, a, clicks, state, ambient_c)
        return out[0], out[1], out[2], out[3], new

    # -- what the plant is --------------------------------------------------------------
    def bulk_modulus_pa(self, p: float) -> float:
        """The oil-and-air mixture's tangent bulk modulus at absolute pressure p."""
        dp = 1e-4 * p
        v = kern.specific_volume(self.k, p)
        dv = kern.specific_volume(self.k, p + dp) - kern.specific_volume(self.k, p - dp)
        return -v * 2 * dp / dv

    def viscosity_pa_s(self, t_c: float) -> float:
        return kern.viscosity(self.k, t_c)


@dataclass(frozen=True)
class PlantTruth:
    """What the plant did, per sweep: the physics it actually showed (a release pressure
    the chamber never reached made no cavities)."""

    max_vapour_m3: float
    oil_temperature_c: tuple[float, float]  # at the first and the last measured sample
    lowest_rebound_pa: float
    # The largest elastic seal force on a measured sample: the breakaway the seal reaches at
    # a reversal on this sweep (F_c + F_b is its level at rest, which a reversing rod,
    # past v_s before the seal has turned, does not reach).
    seal_peak_n: float = math.nan


class _Carried:
    """One damper carried through a sweep's moves: its state and clock, and the truth seen
    so far (the most vapour, the lowest rebound pressure)."""

    def __init__(self, plant: ReferencePlant, ambient_c: float) -> None:
        self.plant = plant
        self.ambient_c = ambient_c
        self.state = plant.initial(0.0, ambient_c)
        self.dt = 1.0 / plant.fs
        self.clock = 0.0
        self.vapour, self.lowest = 0.0, math.inf
        self.seal = np.zeros(0)  # the last move's elastic seal force

    def advance(
        self, x: FloatArray, v: FloatArray, a: FloatArray, c: int
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The move's sensed force, position and body temperature."""
        t = np.asarray(self.clock + self.dt * (1 + np.arange(x.size)), dtype=np.float64)
        out, self.state = self.plant.run_detail(t, x, v, a, (c, 0), self.state, self.ambient_c)
        self.vapour = max(self.vapour, float(np.max(out[6])))
        self.lowest = min(self.lowest, float(np.min(out[5])))
        self.seal = out[8]
        self.clock = float(t[-1])
        return out[1], out[2], out[3]


def _to_mid_stroke(
    last_x: float, sample_rate_hz: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """x, ẋ, ẍ of a 1 s half-cosine move from `last_x` to mid-stroke."""
    dt = 1.0 / sample_rate_hz
    s = np.arange(1, round(sample_rate_hz) + 1) * dt
    move = last_x * (1 + np.cos(math.pi * s)) / 2
    move_v = -last_x * math.pi / 2 * np.sin(math.pi * s)
    move_a = -last_x * math.pi**2 / 2 * np.cos(math.pi * s)
    return move, move_v, move_a


def _ramped_sine(
    k: NDArray[np.floating[Any]],  # Any: numpy's precision parameter (the caller's)
    dt: float,
    f: float,
    amplitude_m: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """x, ẋ, ẍ of a sine at times `k` (step `dt`), its amplitude ramped in."""
    w = 2 * math.pi * f
    # The ram starts from rest: a half-cosine ramp of the amplitude over the first
    # warm-up cycle, so nothing jerks.
    ramp = np.where(k < 1 / f, 0.5 - 0.5 * np.cos(math.pi * k * f), 1.0)
    x = amplitude_m * ramp * np.sin(w * k)
    v = np.asarray(np.gradient(x, dt), dtype=np.float64)
    a = np.asarray(np.gradient(v, dt), dtype=np.float64)
    return x, v, a


def reference_sweep(
    spec: DamperSpec,
    params: PlantParams,
    clicks: list[int],
    frequencies_hz: tuple[float, ...] = (0.5, 1.0, 1.5),
    *,
    cycles: int = 3,
    warmup_cycles: int = 1,
    rest_s: float = 2.0,
    amplitude_m: float = 0.03,
    sample_rate_hz: float = 1000.0,
    ambient_c: float = 40.0,
    lvdt_noise_m: float = 1e-6,
    load_noise_n: float = 2.0,
    temperature_noise_c: float = 0.02,
    seed: int = 0,
) -> tuple[list[TestData], PlantTruth]:
    """A click sweep of the reference plant as a rig would record it, offline (no sockets:
    for benchmarks and tests): tests in order on one damper, its state (and its heat)
    carried from test to test, a rest at mid-stroke between tests, warm-up cycles not
    kept. Returns TestData and the truth."""
    rng = np.random.default_rng(seed)
    run = _Carried(ReferencePlant(spec, params, sample_rate_hz), ambient_c)
    dt = 1.0 / sample_rate_hz
    tests: list[TestData] = []
    temps: list[float] = []
    last_x = 0.0  # the rod is moved, never set: a jump would move no oil
    seal_peak = 0.0
    for c in clicks:
        for f in frequencies_hz:
            if last_x != 0.0:  # back to mid-stroke (the last test ended at the bottom)
                run.advance(*_to_mid_stroke(last_x, sample_rate_hz), c)
            rest = np.zeros(round(rest_s * sample_rate_hz))
            run.advance(rest, rest, rest, c)
            n_warm = round((warmup_cycles + 0.75) / f * sample_rate_hz)
            n = round(cycles / f * sample_rate_hz)
            k = np.arange(n_warm + n + 1) * dt
            x, v, a = _ramped_sine(k, dt, f, amplitude_m)
            run.vapour = 0.0 if not tests else run.vapour
            f_s, x_s, temp = run.advance(x, v, a, c)
            last_x = float(x[-1])
            # Kept from the bottom of the stroke: a rig's recording starts anywhere but
            # exactly on a cycle's own up-crossing.
            first = n_warm
            keep = slice(first, first + n + 1)
            seal_peak = max(seal_peak, float(np.max(np.abs(run.seal[keep]))))
            temps.append(float(run.state.s[kern.TO]))
            meta = TestMeta(
                index=len(tests),
                clicks=int(c),
                gas_clicks=0,
                frequency_hz=float(f),
                amplitude_m=amplitude_m,
                sample_rate_hz=sample_rate_hz,
                measured_cycles=cycles,
            )
            tests.append(
                TestData(
                    meta=meta,
                    t=k[keep] - k[first],
                    x=x_s[keep] + rng.normal(0, lvdt_noise_m, n + 1),
                    force=f_s[keep] + rng.normal(0, load_noise_n, n + 1),
                    temperature=temp[keep] + rng.normal(0, temperature_noise_c, n + 1),
                )
            )
    truth = PlantTruth(run.vapour, (temps[0], temps[-1]), run.lowest, seal_peak)
    return tests, truth
