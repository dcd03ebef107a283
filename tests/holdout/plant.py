"""A monotube damper on a displacement-driven dyno, from first principles, for held-out tests.

Written without reading the project's own physics (model/terms, chamber, composite, flow,
simrig): only the damper spec (sim/ohlins-s46.toml through `load_spec`, the shim-stack
fields of model/shims.py) and the paper. The effects below are this file's own forms.

Conventions: x > 0 is compression (rod into the body), v = dx/dt, force > 0 resists
compression, SI units, pressures absolute, P_ATM = 101 325 Pa.

Geometry and state
------------------
Three volumes: the compression chamber (piston face A_p, oil column L_c = spec.oil_column_m
at x = 0, closed by the floating piston of area A_gp), the rebound chamber (annulus
A_a = A_p - A_rod, column L_r = 0.10 m at x = 0, an assumption: 30 mm of stroke either side
plus the rod guide) and the gas column (L_g = spec.gas_length_m on A_gp, charged to p0 at
x = 0). The floating piston is massless and frictionless, so the compression chamber sits at
the gas pressure; its 40 g is carried as reflected rod mass m_gp (A_rod/A_gp)^2.

    V_c,geo = A_p (L_c - x) + A_gp s            (s: floating-piston travel into the gas)
    V_r,geo = A_a (L_r + x)
    p_g     = p0 · (T_gas / T_fill) · (L_g / (L_g - s))^n,   n = 1.0 (the paper's eq. 5)

The oil is tracked as contents u_c, u_r (m³ at the charge pressure and the fill
temperature), with u_c + u_r = U fixed. A content's volume at pressure p is
θ · u · φ(p) (θ = 1 + γ (T_oil - T_fill) thermal expansion, only with the thermal effect),
plus any released gas. Each chamber is full: content volume = geometric volume, except that
the rebound chamber may hold a vapour void (cavitation, below).

Flow from the compression to the rebound chamber (Δp = p_c - p_r, Q > 0 for Δp > 0):

    Q = q_bleed(|Δp|) + q_valve(|Δp|) (sign of Δp)  +  G_gap Δp  +  (b/2) π D_p v

* bleed: a sharp orifice of the spec's C_D and the click's area A_b (A_bc for Δp > 0, A_bt
  for Δp < 0, from spec.bleed_areas), in series with a laminar resistance:
  |Δp| = a q² + β q, a = ρ / (2 C_D² A_b²); so q = 2|Δp| / (β + sqrt(β² + 4 a |Δp|)).
  β is tiny in the clean plant (the orifice turns laminar below ~100 Pa, i.e. below
  ~1 mm/s of rod speed: a regularisation, not a visible effect); the thermal effect adds the
  needle passage's viscous share (see "thermal").
* shim-stack valve of that direction, in parallel: lift y = (|Δp| A_face - F_pre) / k,
  clipped to [0, max_lift]; an orifice of area perimeter · y with the spec's C_D
  (k, F_pre, perimeter, face area, max lift from model/shims.py ShimStack). The thermal
  effect puts the seat land's Poiseuille resistance β_v = 12 μ L_land / (perimeter · y³) in
  series.
* piston-gap leak: plane Poiseuille G_gap = b³ π D_p / (12 μ L_band) with the spec's gap b
  and band L_band, plus the Couette flux the moving wall drags (b/2) π D_p v (0.1 % of the
  swept flow: kept because it is free).

Rod force measured by the load cell (before the instrument chain):

    F = m_eff ẍ + (p_c - P_ATM) A_rod + (p_c - p_r) A_a + F_seal + F_contact

Time integration (own implicit scheme)
--------------------------------------
The imposed motion x(t) is sampled at 4 kHz (h = 0.25 ms, four sub-steps per 1 kHz sample).
Each sub-step is BDF2 on the rebound content, u_r' = (4 u_r - u_r,prev)/3 + (2h/3) Q(p_c - p_r')/θ
(second order: the flow does not trail the motion by half a step, which would read as a
0.125 ms sensor lag), with the new pressure p_r' found from the rebound chamber's volume
balance (u0 = (4 u_r - u_r,prev)/3, h' = 2h/3)

    R(p) = (θ u0 + h' Q(p_c - p)) φ(p) + V_gas(p) - V_r,geo(x') = 0,

which is strictly decreasing in p, by a bracketed Newton iteration (bisection when Newton
leaves the bracket); p_c follows from the compression chamber's balance with the gas
(explicit for rigid oil, a scalar Newton in s for aerated oil) and the two are iterated to
a fixed point (the coupling is weak: the gas is soft). With rigid oil and no void R(p) = 0 is
the incompressible flow balance Q = A_a (3 x' - 4 x + x_prev)/(2h), so the clean plant has
no integration lag; with compliant oil the scheme is A-stable (rests use backward Euler with
long steps to settle). Speeds and accelerations (seal, Couette, inertia, contact hysteresis)
are the motion's analytic ones. If R(p_vap) < 0 the chamber cannot be
filled at the vapour pressure: p_r = p_vap and the void volume is -R(p_vap).

Effects (each off by default; `Effects` holds the strengths)
------------------------------------------------------------
compressibility (aerated, compliant oil, both chambers):
    φ(p) = (1 - α) exp(-(p - p0)/K_l) + α (p0/p)^(1/κ)
  α = free-air volume fraction at the charge p0 (fine bubbles, fixed over a sweep: their
  dissolution takes minutes), κ = the bubbles' own polytropic index (1.0 isothermal, small
  bubbles; up to 1.3), K_l = oil + tube-wall modulus. The mixture's tangent modulus at the
  charge is K_eff = 1 / ((1 - α)/K_l + α/(κ p0)); it falls steeply where p_r drops in
  compression. This is the effect's "true key value".
cavitation (the vapour floor is always there; the effect is asking for a low charge):
  p_r cannot fall below p_vap = 3 kPa (vapour plus air-release pressure of a degassed oil),
  or below release_pressure_pa where it is set: an oil filled without degassing holds the
  air that saturates it at 1 atm, and gas comes out of it a little below that (gaseous
  cavitation), so its floor is tens of kPa, not the vapour's few.
  The void left behind must be swept full again by the piston after reversal before p_r can
  rise. While a void exists, dissolved gas (the oil is saturated at the charge) comes out into
  it: dV_n/dt = ε V_void (p0/P_ATM) / τ_rel (V_n at P_ATM, τ_rel = 30 ms), and redissolves
  with dV_n/dt = -V_n / τ_dis; the released gas is isothermal, V_gas(p) = V_n P_ATM / p, so it
  leaves a compliance that outlives the void. Truth counts cavitation only if a void of more
  than 1 mm³ formed.
friction (rod seal and piston band): an elastic seal lip with a reset limit. The lip
  deflects with the rod, z' = z + Δx, and slips when its force reaches the sliding limit
      F_lim(v) = F_c + (F_s - F_c) exp(-|v| / v_s)        (Stribeck with exponent 1)
  i.e. z is clipped to ±F_lim/k_s with k_s = F_s / δ_lip; F_seal = k_s z + c_v v. At a
  reversal the lip unloads elastically and re-loads to the breakaway F_s before it slips.
  Without the effect the seal is the spec's Coulomb friction F_c v / sqrt(v² + v_f²) with the
  spec's friction_velocity_m_s (1 mm/s) as v_f.
sensor_lag: the force channel only (the LVDT is untouched): a pure transport delay D (DAQ
  channel skew, done by interpolation at 4 kHz) and a load-cell/amplifier second-order
  response ω_n² / (s² + 2 ζ ω_n s + ω_n²), or (cell_lag_s) a first-order RC amplifier
  1 / (τ s + 1), bilinear at 4 kHz. True key value: the low-frequency delay of the force
  behind the displacement, D + 2 ζ / ω_n + τ.
thermal: oil viscosity from a Vogel law through 24 / 11 / 3.1 cSt at 20 / 40 / 100 °C (the
  spec's 11 cSt at 40 °C; the others typical of a light racing damper oil),
      ν(T) = 0.27745 cSt · exp(420.77 K / (T - 198.81 K)),
  acting on every laminar share: the piston-gap leak, the valve seat land (L_land) and the
  bleed needle passage, whose viscous resistance is β_b = s_b (μ/μ_40) a Q_ref
  (s_b = share of the bleed's pressure drop taken by viscosity at 40 °C at the bleed flow
  of 0.05 m/s rod speed, Q_ref = A_a · 0.05 m/s). The gas follows the body temperature
  (p0 ∝ T_gas), the oil expands with γ = 7e-4 /K (pushing the floating piston). These
  laminar paths exist only in the thermal case: at one fixed temperature they are a
  stiffening that a bleed-area fit absorbs; what the case tests is that they change as the
  oil warms.
  Thermal network (always simulated; the recording's temperature channel is a thermocouple on
  the body, first-order lag 3 s):
      C_oil dT_oil/dt = P_hyd - G_ob (T_oil - T_body)
      C_body dT_body/dt = P_seal + G_ob (T_oil - T_body) - G_ba (T_body - T_amb)
  C_oil = 340 J/K (0.18 kg of oil), C_body = 450 J/K (1 kg steel/aluminium body and
  reservoir), G_ob = 10 W/K (the effect may set it), G_ba = 1.5 W/K, T_amb = 22 °C;
  P_hyd = Δp Q, P_seal = F_seal v. Without the effect the hydraulics ignore temperature (the
  channel still shows the damper warming; clean recordings start at 40 °C).
contact: a microcellular bump rubber past x_b (compression) with a hyperbolic
  densification law and rate hysteresis, and optionally an internal top-out spring past
  -x_t (rebound):
      F_bump = k_b δ / (1 - δ/δ_d) · (1 + η tanh(v / v_h)),  δ = x - x_b > 0,
               δ_d = 20 mm, η = 0.15, v_h = 0.05 m/s
      F_top  = -k_t δ_t (1 + η tanh(-v / v_h)),            δ_t = -x - x_t > 0
spec errors (not missing physics): true gas column = spec · gas_volume_factor, true charge =
  the charge written in the manifest · gas_charge_factor, both stacks' preload · preload_factor.

Instrument chain (every recording): `Daq`. Noise is added before the anti-alias filter (the
analog path) and scaled so that the 1 kHz samples show RMS 2 N (force), 1 µm (LVDT); both
channels then pass the same 4-pole Butterworth anti-alias filter at 200 Hz (2.1 ms group
delay on both, so no relative lag), are sampled every fourth 4 kHz point and quantised to
0.05 N and 1 µm. Temperature: body node → thermocouple lag (3 s) → noise 0.02 °C →
0.01 °C counts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from shockdyno.model.spec import DamperSpec, load_spec

P_ATM = 101_325.0
KELVIN = 273.15
REBOUND_COLUMN_M = 0.10  # rebound chamber's oil column at x = 0 (assumption, see docstring)
P_VAPOUR = 3.0e3  # vapour + air-release pressure of the degassed oil, Pa abs
VOID_TRUTH_M3 = 1e-9  # a void larger than 1 mm³ counts as cavitation
LAMINAR_ORIFICE_PA = 100.0  # below this the bleed orifice is laminar (regularisation)
GAS_INDEX = 1.0  # gas spring polytropic index (the paper's isothermal eq. 5)
RELEASE_TIME_S = 0.03
OIL_EXPANSION_PER_K = 7e-4
# thermal network
C_OIL_J_K = 340.0
C_BODY_J_K = 450.0
G_BODY_AIR_W_K = 1.5
AMBIENT_C = 22.0
THERMOCOUPLE_TAU_S = 3.0
# Vogel viscosity law through 24 / 11 / 3.1 cSt at 20 / 40 / 100 °C
VOGEL_A_CST, VOGEL_B_K, VOGEL_C_K = 0.27745110, 420.771671, 198.810053
# contact law constants
BUMP_DENSE_M = 0.020
CONTACT_HYST = 0.15
CONTACT_V_M_S = 0.05


def viscosity_cst(t_c: float) -> float:
    """Vogel law ν(T) (cSt) of the plant's oil; 11 cSt at 40 °C."""
    return VOGEL_A_CST * math.exp(VOGEL_B_K / (t_c + KELVIN - VOGEL_C_K))


@dataclass(frozen=True)
class Effects:
    """What the plant has beyond the spec's damper. Defaults: the clean plant."""

    # compressibility: aerated, compliant oil in both chambers
    air_fraction: float = 0.0  # free-air volume fraction at the charge
    air_index: float = 1.0  # the bubbles' polytropic index
    liquid_bulk_pa: float = 0.0  # oil + tube modulus; 0 = rigid (clean)
    # cavitation (the void floor is always physical; these shape the released gas)
    gas_release: float = 0.0  # ε: released-gas ratio
    redissolve_s: float = 1.0
    release_pressure_pa: float = 0.0  # the floor; 0 = the degassed oil's P_VAPOUR
    # seal friction: elastic lip with Stribeck reset limit (breakaway_n 0 = plain Coulomb)
    breakaway_n: float = 0.0
    stribeck_velocity_m_s: float = 0.005
    lip_travel_m: float = 1e-4
    seal_viscous_n_s_m: float = 0.0
    # sensor lag on the force channel
    force_delay_s: float = 0.0
    cell_freq_hz: float = 0.0  # 0 = no load-cell dynamics
    cell_damping: float = 0.7
    cell_lag_s: float = 0.0  # a first-order (RC) load-cell amplifier instead; 0 = none
    # thermal
    thermal: bool = False
    land_length_m: float = 0.0
    needle_share: float = 0.0
    oil_body_w_k: float = 10.0
    start_temperature_c: float = 40.0
    # contact
    bump_onset_m: float = math.inf
    bump_k_n_m: float = 0.0
    topout_onset_m: float = math.inf
    topout_k_n_m: float = 0.0
    # the charge the operator set (and writes in the manifest); None = the spec's
    charge_pa: float | None = None
    # spec errors (not missing physics)
    gas_volume_factor: float = 1.0
    gas_charge_factor: float = 1.0
    preload_factor: float = 1.0

    @property
    def compliant(self) -> bool:
        return self.liquid_bulk_pa > 0 or self.air_fraction > 0

    @property
    def stiction(self) -> bool:
        return self.breakaway_n > 0

    @property
    def sensor(self) -> bool:
        return self.force_delay_s > 0 or self.cell_freq_hz > 0 or self.cell_lag_s > 0


class Plant:
    """The damper's state and its time step. `run` drives it through a motion, `rest` lets
    it stand (heat flows, pressures settle, released gas redissolves)."""

    def __init__(self, spec: DamperSpec | None = None, effects: Effects | None = None) -> None:
        self.spec = spec = spec if spec is not None else load_spec()
        self.fx = fx = effects if effects is not None else Effects()
        self.A_p, self.A_rod = spec.piston_area_m2, spec.rod_area_m2
        self.A_a, self.A_gp = spec.annulus_area_m2, spec.gas_piston_area_m2
        self.L_c, self.L_r = spec.oil_column_m, REBOUND_COLUMN_M
        self.L_g = spec.gas_length_m * fx.gas_volume_factor
        nominal = fx.charge_pa if fx.charge_pa is not None else spec.gas_pressure_pa
        self.charge_written_pa = nominal
        self.p0 = nominal * fx.gas_charge_factor
        self.rho = spec.oil_density_kg_m3
        self.cd_s = spec.discharge_coefficient * math.sqrt(2.0 / self.rho)
        self.mu_ref = spec.viscosity_pa_s
        self.m_eff = (
            spec.piston_rod_mass_kg + spec.gas_piston_mass_kg * (self.A_rod / self.A_gp) ** 2
        )
        self.gap_geom = (
            spec.leak_gap_m**3 * math.pi * spec.piston_diameter_m / (12.0 * spec.leak_land_length_m)
        )
        self.couette = spec.leak_gap_m / 2.0 * math.pi * spec.piston_diameter_m
        self.valves = []
        for v in (spec.compression_valve, spec.rebound_valve):
            k = v.stiffness_n_per_m
            self.valves.append(
                (v.perimeter_m, v.face_area_m2, k, v.preload_n * fx.preload_factor, v.max_lift_m)
            )
        self.U = self.A_a * self.L_r + self.A_p * self.L_c
        self.k_lip = fx.breakaway_n / fx.lip_travel_m if fx.stiction else 0.0
        # The floor; read here, not at import, so that a counterfactual run can set the
        # module's P_VAPOUR far below vacuum (benchmarks/holdout_visibility.py) and have
        # no floor at all, whatever the oil's.
        custom = fx.release_pressure_pa > 0 and P_VAPOUR > 0
        self.p_v = fx.release_pressure_pa if custom else P_VAPOUR
        # state
        self.u_r = self.u_prev = self.A_a * self.L_r
        self.s = 0.0
        self.p_c = self.p_r = self.p0
        self.Vn = 0.0
        self.void = 0.0
        self.z = 0.0
        self.x = 0.0
        self.q_last = 0.0
        self.T_fill = fx.start_temperature_c
        self.T_oil = self.T_body = fx.start_temperature_c
        self.set_clicks(0)

    # -- settings ----------------------------------------------------------------------
    def set_clicks(self, clicks: int) -> None:
        a_bc, a_bt = self.spec.bleed_areas(clicks)
        self.clicks = clicks
        self.area_b = (float(a_bc), float(a_bt))
        self._bleed = []
        for area in self.area_b:
            if area <= 0:
                self._bleed.append((0.0, 0.0, 0.0))
                continue
            a = 1.0 / (self.cd_s * area) ** 2  # |Δp| = a q² for the orifice
            b_reg = math.sqrt(4.0 * a * LAMINAR_ORIFICE_PA)
            q_ref = self.A_a * 0.05
            b_visc40 = self.fx.needle_share * a * q_ref if self.fx.thermal else 0.0
            self._bleed.append((a, b_reg, b_visc40))

    # -- physics pieces ----------------------------------------------------------------
    def mu(self) -> float:
        if not self.fx.thermal:
            return self.mu_ref
        return viscosity_cst(self.T_oil) * 1e-6 * self.rho

    def _path(self, d: float, direction: int, mu_ratio: float, land: float) -> tuple[float, float]:
        """One direction's bleed + valve flow for d = |Δp| >= 0: (q, dq/dd)."""
        q = dq = 0.0
        a, b_reg, b_v40 = self._bleed[direction]
        if a > 0:
            b = b_reg + b_v40 * mu_ratio
            s = math.sqrt(b * b + 4.0 * a * d)
            den = b + s
            q = 2.0 * d / den
            dq = 2.0 * (den - 2.0 * a * d / s) / (den * den)
        perim, face, k, pre, ymax = self.valves[direction]
        y = (d * face - pre) / k
        if y > 0:
            dy = face / k
            if y >= ymax:
                y, dy = ymax, 0.0
            if land <= 0:
                sd = math.sqrt(d)
                q += self.cd_s * perim * y * sd
                dq += self.cd_s * perim * (dy * sd + y / (2.0 * sd))
            else:
                av = perim * y
                a_v = 1.0 / (self.cd_s * av) ** 2
                b_v = land / (perim * y**3)
                da = -2.0 * a_v * dy / y
                db = -3.0 * b_v * dy / y
                s = math.sqrt(b_v * b_v + 4.0 * a_v * d)
                den = b_v + s
                dden = db + (2.0 * b_v * db + 4.0 * da * d + 4.0 * a_v) / (2.0 * s)
                q += 2.0 * d / den
                dq += (2.0 * den - 2.0 * d * dden) / (den * den)
        return q, dq

    def flow(self, dp: float, v: float, mu: float) -> tuple[float, float]:
        """Flow compression -> rebound chamber at Δp = p_c - p_r, rod speed v: (Q, dQ/dΔp)."""
        mu_ratio = mu / self.mu_ref
        land = 12.0 * mu * self.fx.land_length_m if self.fx.thermal else 0.0
        if dp >= 0:
            q, dq = self._path(dp, 0, mu_ratio, land)
        else:
            q, dq = self._path(-dp, 1, mu_ratio, land)
            q = -q
        g = self.gap_geom / mu
        return q + g * dp + self.couette * v, dq + g

    def phi(self, p: float) -> tuple[float, float]:
        """Volume of unit content at pressure p (relative to the charge) and its slope."""
        fx = self.fx
        if not fx.compliant:
            return 1.0, 0.0
        al = fx.air_fraction
        f, df = 0.0, 0.0
        if fx.liquid_bulk_pa > 0:
            e = math.exp(-(p - self.p0) / fx.liquid_bulk_pa)
            f += (1.0 - al) * e
            df -= (1.0 - al) * e / fx.liquid_bulk_pa
        else:
            f += 1.0 - al
        if al > 0:
            r = (self.p0 / p) ** (1.0 / fx.air_index)
            f += al * r
            df -= al * r / (fx.air_index * p)
        return f, df

    def gas_pressure(self, s: float) -> float:
        tau = (self.T_body + KELVIN) / (self.T_fill + KELVIN) if self.fx.thermal else 1.0
        return self.p0 * tau * (self.L_g / (self.L_g - s)) ** GAS_INDEX

    def theta(self) -> float:
        if not self.fx.thermal:
            return 1.0
        return 1.0 + OIL_EXPANSION_PER_K * (self.T_oil - self.T_fill)

    def _compression(self, x: float, content: float) -> tuple[float, float]:
        """Floating-piston travel s and p_c for compression-chamber content (volume at the
        charge, already times θ)."""
        base = self.A_p * (self.L_c - x)
        if not self.fx.compliant:
            s = (content - base) / self.A_gp
            return s, self.gas_pressure(s)
        s = self.s
        for _ in range(50):
            pg = self.gas_pressure(s)
            f, df = self.phi(pg)
            dpg = GAS_INDEX * pg / (self.L_g - s)
            g = base + self.A_gp * s - content * f
            dg = self.A_gp - content * df * dpg
            step = g / dg
            s -= step
            if abs(step) < 1e-12:
                break
        return s, self.gas_pressure(s)

    def contact_force(self, x: float, v: float) -> float:
        fx = self.fx
        f = 0.0
        d = x - fx.bump_onset_m
        if d > 0:
            d = min(d, 0.95 * BUMP_DENSE_M)
            f += (
                fx.bump_k_n_m
                * d
                / (1.0 - d / BUMP_DENSE_M)
                * (1.0 + CONTACT_HYST * math.tanh(v / CONTACT_V_M_S))
            )
        d = -x - fx.topout_onset_m
        if d > 0:
            f -= fx.topout_k_n_m * d * (1.0 + CONTACT_HYST * math.tanh(-v / CONTACT_V_M_S))
        return f

    def seal_force(self, dx: float, v: float) -> float:
        fx = self.fx
        if not fx.stiction:
            ve = self.spec.friction_velocity_m_s
            return self.spec.friction_n * v / math.sqrt(v * v + ve * ve)
        fc = self.spec.friction_n
        lim = (fc + (fx.breakaway_n - fc) * math.exp(-abs(v) / fx.stribeck_velocity_m_s)) / (
            self.k_lip
        )
        z = self.z + dx
        z = max(-lim, min(lim, z))
        self.z = z
        return self.k_lip * z + fx.seal_viscous_n_s_m * v

    # -- the rebound chamber's balance -------------------------------------------------
    def _rebound(
        self, p_c: float, vgeo: float, h: float, v: float, mu: float, th: float, u0: float
    ) -> tuple[float, float, float]:
        """Solve R(p) = 0 for the rebound pressure, (u0 + h Q/θ) being the new content:
        (p_r, Q, void)."""
        ur = th * u0
        vn = self.Vn
        compliant = self.fx.compliant

        def resid(p: float) -> tuple[float, float, float]:
            q, dq = self.flow(p_c - p, v, mu)
            if compliant:
                f, df = self.phi(p)
            else:
                f, df = 1.0, 0.0
            c = ur + h * q
            r = c * f - vgeo
            dr = -h * dq * f + c * df
            if vn > 0:
                r += vn * P_ATM / p
                dr -= vn * P_ATM / (p * p)
            return r, dr, q

        p_v = self.p_v
        lo, hi = p_v, math.inf
        lo_checked = False
        p = max(self.p_r, p_v * 1.5)
        q = 0.0
        for _ in range(100):
            r, dr, q = resid(p)
            if r >= 0:
                lo, lo_checked = p, True
            else:
                hi = p
            pn = p - r / dr if dr < 0 else 0.5 * (lo + hi)
            if not lo < pn < hi:
                if not lo_checked:
                    rv, _, qv = resid(p_v)
                    lo_checked = True
                    if rv < 0:
                        return p_v, qv, -rv
                pn = 0.5 * (lo + hi) if hi < math.inf else 2.0 * p
            if abs(pn - p) < 0.02:
                p = pn
                r, dr, q = resid(p)
                break
            p = pn
        return p, q, 0.0

    def step(
        self, x_new: float, h: float, v: float = 0.0, xdd: float = 0.0, bdf2: bool = True
    ) -> float:
        """Advance by h to rod position x_new (speed v, acceleration xdd there); return the
        rod force (N). The content update is BDF2 (second order, no half-step lag of the
        flow behind the motion) unless bdf2=False (backward Euler: a change of step)."""
        dx = x_new - self.x
        if bdf2:
            u0, hq = (4.0 * self.u_r - self.u_prev) / 3.0, 2.0 * h / 3.0
        else:
            u0, hq = self.u_r, h
        th = self.theta()
        mu = self.mu()
        vgeo = self.A_a * (self.L_r + x_new)
        # first guess of the new rebound content: the chamber full at the last pressure
        f_r, _ = self.phi(self.p_r)
        gas_r = self.Vn * P_ATM / self.p_r if self.Vn > 0 else 0.0
        ur_new = (vgeo - gas_r - self.void) / (th * f_r)
        p_c = self.p_c
        p_r = self.p_r
        q = 0.0
        void = 0.0
        for _ in range(8):
            s, p_c_new = self._compression(x_new, th * (self.U - ur_new))
            self.s = s
            p_c_changed = abs(p_c_new - p_c)
            p_c = p_c_new
            p_r, q, void = self._rebound(p_c, vgeo, hq, v, mu, th, u0)
            ur_new = u0 + hq * q / th
            if p_c_changed < 0.05:
                break
        dp = p_c - p_r
        self.u_prev = self.u_r if bdf2 else ur_new
        self.u_r = ur_new
        self.p_c, self.p_r, self.void, self.x, self.q_last = p_c, p_r, void, x_new, q
        fx = self.fx
        # released gas (backward Euler), driven by the void
        if void > 0 or self.Vn > 0:
            rel = fx.gas_release * void * (self.p0 / P_ATM) / RELEASE_TIME_S
            self.Vn = (self.Vn + h * rel) / (1.0 + h / fx.redissolve_s)
        f_seal = self.seal_force(dx, v)
        # heat
        p_hyd = abs(dp * (q - self.couette * v))
        p_seal = abs(f_seal * v)
        g_ob = fx.oil_body_w_k
        d_oil = (p_hyd - g_ob * (self.T_oil - self.T_body)) / C_OIL_J_K
        d_body = (
            p_seal + g_ob * (self.T_oil - self.T_body) - G_BODY_AIR_W_K * (self.T_body - AMBIENT_C)
        ) / C_BODY_J_K
        self.T_oil += h * d_oil
        self.T_body += h * d_body
        return (
            self.m_eff * xdd
            + (p_c - P_ATM) * self.A_rod
            + dp * self.A_a
            + f_seal
            + self.contact_force(x_new, v)
        )

    def force_at_rest(self) -> float:
        """The force with the rod held (lip force and pressures as they stand)."""
        return (
            (self.p_c - P_ATM) * self.A_rod
            + (self.p_c - self.p_r) * self.A_a
            + self.k_lip * self.z
            + self.contact_force(self.x, 0.0)
        )

    def run(
        self,
        x: NDArray[np.float64],
        xd: NDArray[np.float64],
        xdd: NDArray[np.float64],
        h: float,
    ) -> dict[str, NDArray[np.float64]]:
        """Drive the rod through x (sampled every h, x[0] = where it is now, at rest), with
        its speed xd and acceleration xdd."""
        n = len(x)
        force = np.empty(n)
        t_body = np.empty(n)
        t_oil = np.empty(n)
        void = np.empty(n)
        p_r = np.empty(n)
        lip = np.empty(n)  # the lip's elastic force (its viscous drag apart)
        force[0] = self.force_at_rest()
        t_body[0], t_oil[0], void[0], p_r[0] = self.T_body, self.T_oil, self.void, self.p_r
        lip[0] = self.k_lip * self.z
        step = self.step
        for i in range(1, n):
            force[i] = step(float(x[i]), h, float(xd[i]), float(xdd[i]))
            t_body[i], t_oil[i], void[i], p_r[i] = self.T_body, self.T_oil, self.void, self.p_r
            lip[i] = self.k_lip * self.z
        return {
            "force": force,
            "t_body": t_body,
            "t_oil": t_oil,
            "void": void,
            "p_r": p_r,
            "lip": lip,
        }

    def rest(self, seconds: float) -> None:
        """Hold the rod for `seconds`: pressures settle, gas redissolves, heat flows."""
        for _ in range(20):  # settle the hydraulics with long implicit steps
            self.step(self.x, 0.01, bdf2=False)
        self.Vn *= math.exp(-max(seconds - 0.2, 0.0) / self.fx.redissolve_s)
        dt = 0.05
        g_ob = self.fx.oil_body_w_k
        for _ in range(int(max(seconds - 0.2, 0.0) / dt)):
            d_oil = -g_ob * (self.T_oil - self.T_body) / C_OIL_J_K
            d_body = (
                g_ob * (self.T_oil - self.T_body) - G_BODY_AIR_W_K * (self.T_body - AMBIENT_C)
            ) / C_BODY_J_K
            self.T_oil += dt * d_oil
            self.T_body += dt * d_body

    # -- what the effects truly are ------------------------------------------------------
    def true_values(self) -> dict[str, Any]:
        fx, spec = self.fx, self.spec
        out: dict[str, Any] = {}
        if fx.compliant:
            kl = fx.liquid_bulk_pa if fx.liquid_bulk_pa > 0 else math.inf
            comp = (1 - fx.air_fraction) / kl + fx.air_fraction / (fx.air_index * self.p0)
            out["bulk_modulus_at_charge_pa"] = 1.0 / comp
            out["air_fraction"] = fx.air_fraction
        if fx.stiction:
            out["breakaway_n"] = fx.breakaway_n
            out["coulomb_n"] = spec.friction_n
            out["stribeck_velocity_m_s"] = fx.stribeck_velocity_m_s
            out["seal_viscous_n_s_m"] = fx.seal_viscous_n_s_m
        if fx.sensor:
            lag = fx.force_delay_s
            if fx.cell_freq_hz > 0:
                lag += 2 * fx.cell_damping / (2 * math.pi * fx.cell_freq_hz)
            lag += fx.cell_lag_s
            out["force_delay_s"] = lag
            out["transport_delay_s"] = fx.force_delay_s
            out["cell_freq_hz"] = fx.cell_freq_hz
            out["cell_lag_s"] = fx.cell_lag_s
        if math.isfinite(fx.bump_onset_m):
            out["bump_onset_m"] = fx.bump_onset_m
            out["bump_k_n_m"] = fx.bump_k_n_m
        if math.isfinite(fx.topout_onset_m):
            out["topout_onset_m"] = -fx.topout_onset_m
            out["topout_k_n_m"] = fx.topout_k_n_m
        out["release_pressure_pa"] = self.p_v
        out["gas_charge_true_pa"] = self.p0
        out["gas_charge_written_pa"] = self.charge_written_pa
        return out


class Daq:
    """The dyno's instrument chain: 4 kHz analog signals in, 1 kHz recorded samples out."""

    def __init__(
        self,
        effects: Effects,
        rng: np.random.Generator,
        fs_in: float = 4000.0,
        decimate: int = 4,
        noise: bool = True,
    ) -> None:
        self.fx, self.rng, self.fs_in, self.m = effects, rng, fs_in, decimate
        self.noise = noise
        self.aa = signal.butter(4, 200.0, fs=fs_in, output="sos")
        imp = signal.sosfilt(self.aa, np.r_[1.0, np.zeros(4095)])
        self.aa_gain = float(np.sqrt(np.sum(imp**2)))  # RMS gain for white noise
        self.cell = None
        if effects.cell_freq_hz > 0:
            wn = 2 * fs_in * math.tan(math.pi * effects.cell_freq_hz / fs_in)  # pre-warped
            z = effects.cell_damping
            b, a = signal.bilinear([wn * wn], [1.0, 2 * z * wn, wn * wn], fs=fs_in)
            self.cell = signal.tf2sos(b, a)
        if effects.cell_lag_s > 0:
            # An RC amplifier 1 / (τ s + 1), bilinear at the analog rate (a single pole).
            b, a = signal.bilinear([1.0], [effects.cell_lag_s, 1.0], fs=fs_in)
            rc = signal.tf2sos(b, a)
            self.cell = rc if self.cell is None else np.vstack([self.cell, rc])
        self.tc: float | None = None

    def _aa(self, sig: NDArray[np.float64], sigma: float) -> NDArray[np.float64]:
        if self.noise and sigma > 0:
            sig = sig + self.rng.normal(0.0, sigma / self.aa_gain, len(sig))
        zi = signal.sosfilt_zi(self.aa) * sig[0]
        return signal.sosfilt(self.aa, sig, zi=zi)[0][:: self.m]

    def force(self, t: NDArray[np.float64], f: NDArray[np.float64]) -> NDArray[np.float64]:
        fx = self.fx
        if fx.force_delay_s > 0:
            f = np.interp(t - fx.force_delay_s, t, f)
        if self.cell is not None:
            zi = signal.sosfilt_zi(self.cell) * f[0]
            f = signal.sosfilt(self.cell, f, zi=zi)[0]
        return np.round(self._aa(f, 2.0) / 0.05) * 0.05

    def displacement(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.round(self._aa(x, 1e-6) / 1e-6) * 1e-6

    def temperature(self, t_body: NDArray[np.float64]) -> NDArray[np.float64]:
        tb = t_body[:: self.m]
        a = 1.0 - math.exp(-self.m / self.fs_in / THERMOCOUPLE_TAU_S)
        out = np.empty(len(tb))
        y = float(tb[0]) if self.tc is None else self.tc
        for i, v in enumerate(tb):
            y += a * (v - y)
            out[i] = y
        self.tc = y
        if self.noise:
            out = out + self.rng.normal(0.0, 0.02, len(out))
        return np.round(out / 0.01) * 0.01

    def rest(self, seconds: float, t_body_end: float) -> None:
        if self.tc is not None:
            self.tc = t_body_end + (self.tc - t_body_end) * math.exp(-seconds / THERMOCOUPLE_TAU_S)
