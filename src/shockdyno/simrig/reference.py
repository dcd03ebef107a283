"""A reference damper plant written apart from the model the fit uses.

The diagnosis fits the term library (`model/terms/`); a rig that evaluated the same code
would only test the search against itself. This plant imports nothing from the model
but the damper's description (`DamperSpec`: geometry, valves, bleed areas per click),
and writes its physics in its own forms, as states integrated by a stiff solver
(scipy's LSODA: BDF where stiff; Radau was as accurate, and stalled where the ram
stops):

    p_r, p_k   rebound / compression chamber pressures, each a compliance
               a₀ p₀/p² + (V - a₀ p₀/p)/β_oil (a fixed mass of isothermal air, a₀ = α of
               the chamber's mid-stroke volume at p₀: Wood's law) filled by the flows
               through the piston (the oil's mass passes: each side takes it at its
               own density), the rod's and the gas piston's motion
    y_g, u_g   floating gas piston: mass, gas spring p₀ (V_g/(V_g - A_g y_g))^n, seal
    V_v        vapour / released gas in the rebound chamber: forms at rate
               k_e (p_v - p_r) below the release pressure, condenses at k_c (p_r - p_v)
    z          rod-seal bristle deflection (LuGre: Stribeck breakaway, presliding)
    T_o, T_b   oil and body temperatures: oil <- dissipated power, oil -> body -> ambient

Piston flow, Δp = p_k - p_r: each bleed is a laminar + turbulent resistance,
Δp = R_l(T) q + R_t q|q| (R_l from Hagen-Poiseuille over a land, so viscosity acts on its
laminar share); each shim stack opens smoothly (a softplus over its crack pressure, a
rounded stop) to a
turbulent orifice of its own discharge coefficient; the piston's gap leaks laminar flow
and drags Couette flow. Viscosity follows the oil's temperature. A bump stop pushes
k (x - x_b)^m past its onset. The sensor chain low-passes both channels (second-order
Butterworth anti-alias) and samples the force channel `force_skew_s` after the position.

Defaults are a clean damper close to the paper's: oil as stiff as the paper assumes (100 GPa:
mineral oil's 1.6 GPa is an effect here, as it lags visibly behind a nearly closed
bleed), no air, vapour
pressure 3 kPa, no breakaway beyond Coulomb, viscosity held, no bump stop, no skew.
Scenario files select it with `[plant] kind = "reference"` (docs/scenarios.md).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Annotated, Any

import numpy as np
from msgspec import Meta
from numpy.typing import NDArray

from shockdyno.model.spec import DamperSpec
from shockdyno.schema import NonNegative, Positive, convert

FloatArray = NDArray[np.float64]
P_ATM = 101_325.0
# LSODA (BDF where the system is stiff, Adams where it is not): as accurate as Radau here
# (0.006 N RMS apart on a sine, 0.12 N where vapour forms) and far quicker where the ram
# stops, where the gas piston on its seal made Radau take 1.2 s for 40 samples (0.2 s).
METHOD = "LSODA"
FALLBACK = "Radau"  # where LSODA fails to converge (long offline sweeps, now and then)
P_MIN = 500.0  # Pa absolute: the air law's floor (the vapour state keeps p_r above it)


@dataclass(frozen=True)
class PlantParams:
    """A scenario's [plant] table (read through shockdyno.schema: the types are the checks)."""

    # oil
    oil_bulk_modulus_pa: Positive = 1.0e11  # the paper's rigid oil; mineral oil is 1.6e9
    air_fraction: Annotated[float, Meta(ge=0, lt=0.5)] = 0.0  # free air by volume at the gas charge
    release_pressure_pa: NonNegative = 3.0e3  # vapour / air release (absolute)
    vapour_rate_m3_s_pa: NonNegative = 1.0e-7  # k_e: how fast vapour forms below p_v
    condense_rate_m3_s_pa: NonNegative = 1.0e-8  # k_c: how fast it goes back above p_v
    bleed_land_m: NonNegative = 0.004  # laminar length of a bleed passage
    valve_discharge: Positive = 0.7
    valve_smoothing_pa: Positive = 2.0e3  # softplus width of the stack's crack
    # gas
    gas_pressure_factor: Positive = 1.0  # × the spec's charge
    gas_volume_factor: Positive = 1.0  # × the spec's gas volume
    polytropic_index: Positive = 1.0
    gas_thermal_coupling: NonNegative = 0.0  # 1: the gas at the oil's temperature
    gas_seal_n: NonNegative = 8.0
    # rod seal (LuGre)
    breakaway_n: NonNegative = 0.0  # above the spec's Coulomb friction
    stribeck_velocity_m_s: Positive = 0.005
    seal_stiffness_n_m: NonNegative = 2.0e7
    seal_damping_n_s_m: NonNegative = 0.0
    seal_viscous_n_s_m: NonNegative = 0.0
    # thermal network
    viscosity_coeff_per_k: NonNegative = 0.0  # ν ∝ exp(-b (T_o - 40 °C))
    oil_heat_capacity_j_k: Positive = 300.0
    body_heat_capacity_j_k: Positive = 900.0
    oil_to_body_w_k: NonNegative = 6.0
    body_to_ambient_w_k: NonNegative = 2.5
    heating_factor: NonNegative = 1.0  # × the dissipated power that reaches the oil
    start_temperature_c: Annotated[float, Meta(ge=-273.15)] = math.nan  # NaN: the rig's ambient
    # bump stop
    bump_onset_m: NonNegative = math.inf
    bump_force_at_10mm_n: NonNegative = 0.0
    bump_exponent: NonNegative = 2.3
    # sensors
    anti_alias_hz: Positive = 400.0
    force_skew_s: NonNegative = 0.0

    @staticmethod
    def from_table(table: dict[str, Any], source: str, at: str = "plant") -> PlantParams:
        return convert({k: v for k, v in table.items() if k != "kind"}, PlantParams, source, at)


@dataclass
class PlantState:
    y: FloatArray  # p_r, p_k, y_g, u_g, V_v, z, T_o, T_b
    t_s: float
    x_m: float
    v_m_s: float
    force_zi: FloatArray
    pos_zi: FloatArray
    skew_buf: FloatArray  # the last force samples, for the channel skew


class ReferencePlant:
    """The plant: `run` gives a chunk of samples, carrying its state explicitly."""

    def __init__(self, spec: DamperSpec, params: PlantParams, fs_hz: float) -> None:
        self.spec = spec
        self.p = params
        self.fs = fs_hz
        s = spec
        self.a_p = s.piston_area_m2
        self.a_rod = s.rod_area_m2
        self.a_a = self.a_p - self.a_rod
        self.a_g = s.gas_piston_area_m2
        self.v_gas = self.a_g * s.gas_length_m * params.gas_volume_factor
        self.p0 = s.gas_pressure_pa * params.gas_pressure_factor
        self.length = s.oil_column_m
        # Each chamber's free air at the charge: α of its mid-stroke volume, a fixed amount.
        self.air_r = params.air_fraction * self.a_a * self.length
        self.air_k = params.air_fraction * self.a_p * self.length
        self.couette = s.leak_gap_m / 2 * math.pi * s.piston_diameter_m
        self.gap_coeff = (
            s.leak_gap_m**3 * math.pi * s.piston_diameter_m / (12 * s.leak_land_length_m)
        )
        self.mu40 = s.oil_viscosity_cst * 1e-6 * s.oil_density_kg_m3
        self.k_bump = (
            params.bump_force_at_10mm_n / 0.010**params.bump_exponent
            if params.bump_force_at_10mm_n > 0
            else 0.0
        )
        self.valves = []
        for v in (s.compression_valve, s.rebound_valve):
            self.valves.append(
                (v.perimeter_m, v.face_area_m2, v.preload_n, v.stiffness_n_per_m, v.max_lift_m)
            )
        from scipy.signal import butter  # here: scipy.signal takes a second to import

        b, a = butter(2, min(params.anti_alias_hz, 0.45 * fs_hz), fs=fs_hz)
        self._aa_b, self._aa_a = np.asarray(b, float), np.asarray(a, float)
        self._skew = params.force_skew_s * fs_hz
        self.areas = (0.0, 0.0)

    # -- physics ------------------------------------------------------------------------
    def _viscosity(self, t_oil: float) -> float:
        return self.mu40 * math.exp(-self.p.viscosity_coeff_per_k * (t_oil - 40.0))

    def _bleed(self, dp: float, area: float, mu: float) -> float:
        if area <= 0.0 or dp == 0.0:
            return 0.0
        rho = self.spec.oil_density_kg_m3
        cd = self.spec.discharge_coefficient
        r_t = rho / (2 * cd * cd * area * area)
        d_h = math.sqrt(4 * area / math.pi)
        r_l = 128 * mu * self.p.bleed_land_m / (math.pi * d_h**4)
        mag = 2 * abs(dp) / (r_l + math.sqrt(r_l * r_l + 4 * r_t * abs(dp)))
        return math.copysign(mag, dp)

    def _valve(self, dp: float) -> float:
        perim, face, preload, stiff, lift_max = self.valves[0 if dp > 0 else 1]
        over = (abs(dp) * face - preload) / face  # Pa above the crack pressure
        w = self.p.valve_smoothing_pa
        soft = w * (math.log1p(math.exp(over / w)) if over < 30 * w else over / w)
        r = soft * face / (stiff * lift_max)  # the stack's free lift over its stop
        lift = lift_max * r / (1.0 + r**8) ** 0.125  # a rounded stop, not a clip
        q = (
            self.p.valve_discharge
            * perim
            * lift
            * math.sqrt(2 * abs(dp) / self.spec.oil_density_kg_m3)
        )
        return math.copysign(q, dp)

    def _compliance(self, volume: float, air0: float, p: float) -> float:
        """dV/dp of a chamber's contents: a fixed mass of air (air0 of volume at p0,
        isothermal) and the oil that fills the rest. With the air's amount fixed, a cycle
        returns the contents to their volume and moves no oil on balance (a compliance
        V(x)·α p0/p², air scaled with the chamber, pumped oil through the piston every
        cycle and drained the gas side by some 18 kPa a cycle at 2 % air)."""
        pe = max(p, P_MIN)
        air = air0 * self.p0 / pe
        return air0 * self.p0 / (pe * pe) + max(volume - air, 0.0) / self.p.oil_bulk_modulus_pa

    def _volumes_moved(self, q: float, p_r: float, p_k: float) -> tuple[float, float]:
        """(volume arriving in the rebound chamber, volume leaving the compression
        chamber) per second for a piston flow q (k -> r positive, at the upstream
        pressure). The oil's mass is what passes: ρ(p_up) q, with ρ ∝ exp(p/β_oil), so
        the side downstream takes it at its own, lower density. One volume for both
        sides lost mass at ρ q Δp/β, the dissipated power over β: at 1.6 GPa the gas
        piston ended 61 µm off after three 30 mm cycles (click 10, 1.5 Hz), and a
        sweep's force fell 13 N below stiff oil's by its last test."""
        up = p_k if q > 0.0 else p_r
        beta = self.p.oil_bulk_modulus_pa
        return q * math.exp((up - p_r) / beta), q * math.exp((up - p_k) / beta)

    def _gas(self, y_g: float, t_oil: float) -> float:
        v = max(self.v_gas - self.a_g * y_g, 0.05 * self.v_gas)
        p = self.p0 * (self.v_gas / v) ** self.p.polytropic_index
        k = self.p.gas_thermal_coupling
        if k:
            p *= 1 + k * ((t_oil + 273.15) / (40.0 + 273.15) - 1)
        return float(p)

    def _seal_g(self, v: float) -> float:
        p = self.p
        g = self.spec.friction_n + p.breakaway_n * math.exp(-((v / p.stribeck_velocity_m_s) ** 2))
        return max(g, 1e-3)  # no seal friction at all: the bristles never load

    def rates(self, y: FloatArray, x: float, v: float) -> tuple[FloatArray, float]:
        """dy/dt and the rod force (without inertia) at state y, position x, velocity v."""
        p_r, p_k, y_g, u_g, vap, z, t_o, t_b = y
        p = self.p
        a_bc, a_bt = self.areas
        mu = self._viscosity(t_o)
        dp = p_k - p_r
        q = self._bleed(dp, a_bc if dp > 0 else a_bt, mu) + self._valve(dp)
        q += self.gap_coeff / mu * dp + self.couette * v
        if p_r < p.release_pressure_pa:
            dvap = p.vapour_rate_m3_s_pa * (p.release_pressure_pa - p_r)
        else:
            dvap = -p.condense_rate_m3_s_pa * (p_r - p.release_pressure_pa) * vap / (vap + 1e-9)
        v_r = self.a_a * max(self.length + x, 0.1 * self.length)
        v_k = max(self.a_p * (self.length - x) + self.a_g * y_g, 0.1 * self.a_p * self.length)
        q_r, q_k = self._volumes_moved(q, p_r, p_k)
        dp_r = (q_r - self.a_a * v + dvap) / self._compliance(
            max(v_r - vap, 0.1 * v_r), self.air_r, p_r
        )
        dp_k = (self.a_p * v - self.a_g * u_g - q_k) / self._compliance(v_k, self.air_k, p_k)
        f_gs = p.gas_seal_n * math.tanh(u_g / 0.002)
        du_g = ((p_k - self._gas(y_g, t_o)) * self.a_g - f_gs) / self.spec.gas_piston_mass_kg
        g = self._seal_g(v)
        dz = v - p.seal_stiffness_n_m * abs(v) * z / g
        f_seal = p.seal_stiffness_n_m * z + p.seal_damping_n_s_m * dz + p.seal_viscous_n_s_m * v
        power = abs(dp * q) + abs(f_seal * v)
        dt_o = (
            p.heating_factor * power - p.oil_to_body_w_k * (t_o - t_b)
        ) / p.oil_heat_capacity_j_k
        dt_b = (
            p.oil_to_body_w_k * (t_o - t_b) - p.body_to_ambient_w_k * (t_b - self._ambient)
        ) / p.body_heat_capacity_j_k
        force = p_k * self.a_p - p_r * self.a_a - P_ATM * self.a_rod + f_seal
        if x > p.bump_onset_m:
            force += self.k_bump * (x - p.bump_onset_m) ** p.bump_exponent
        return np.array([dp_r, dp_k, u_g, du_g, dvap, dz, dt_o, dt_b]), force

    # -- chunks -------------------------------------------------------------------------
    def initial(self, x0: float, ambient_c: float) -> PlantState:
        self._ambient = ambient_c
        t0 = ambient_c if math.isnan(self.p.start_temperature_c) else self.p.start_temperature_c
        # Static equilibrium at x0: the gas piston has taken the rod's volume.
        y_g = self.a_rod * x0 / self.a_g
        p = self._gas(y_g, t0)
        y = np.array([p, p, y_g, 0.0, 0.0, 0.0, t0, t0])
        from scipy.signal import lfilter_zi

        zi = lfilter_zi(self._aa_b, self._aa_a)
        n_skew = math.ceil(self._skew) + 2
        f0 = (p - P_ATM) * self.a_rod
        return PlantState(
            y=y,
            t_s=-1.0 / self.fs,
            x_m=x0,
            v_m_s=0.0,
            force_zi=zi * f0,
            pos_zi=zi * x0,
            skew_buf=np.full(n_skew, f0),
        )

    def run(
        self,
        t: FloatArray,
        x: FloatArray,
        v: FloatArray,
        a: FloatArray,
        areas: tuple[float, float],
        state: PlantState,
        ambient_c: float,
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, PlantState]:
        """(true force, sensed force, sensed position, body temperature, new state)."""
        self.areas = areas
        self._ambient = ambient_c
        tt = np.concatenate([[state.t_s], t])
        xx = np.concatenate([[state.x_m], x])
        vv = np.concatenate([[state.v_m_s], v])

        def rhs(time: float, y: FloatArray) -> FloatArray:
            xi = float(np.interp(time, tt, xx))
            vi = float(np.interp(time, tt, vv))
            return self.rates(y, xi, vi)[0]

        def solve(method: str) -> Any:
            from scipy.integrate import solve_ivp  # here: a third of a second to import

            return solve_ivp(
                rhs,
                (float(tt[0]), float(tt[-1])),
                state.y,
                method=method,
                t_eval=t,
                rtol=1e-6,
                atol=np.array([1.0, 1.0, 1e-9, 1e-6, 1e-12, 1e-9, 1e-4, 1e-4]),
                max_step=float(tt[-1] - tt[0]) or 1e-3,
            )

        sol = None
        with warnings.catch_warnings():
            # LSODA says "repeated convergence failures" as a warning: take it as a failure
            warnings.simplefilter("error", UserWarning)
            try:
                sol = solve(METHOD)
            except (UserWarning, RuntimeError, ValueError):
                sol = None
        if sol is None or not sol.success:
            sol = solve(FALLBACK)  # slower, and it has not failed where LSODA did
        if not sol.success:
            raise RuntimeError(f"reference plant: the integration failed ({sol.message})")
        ys = sol.y
        force = np.empty(t.size)
        for i in range(t.size):
            force[i] = self.rates(ys[:, i], float(x[i]), float(v[i]))[1]
        force += self.spec.piston_rod_mass_kg * a
        # Sensors: both channels through the anti-alias filter; the force channel sampled
        # `force_skew_s` late (linear interpolation in the carried history).
        from scipy.signal import lfilter

        f_aa, fzi = lfilter(self._aa_b, self._aa_a, force, zi=state.force_zi)
        x_aa, xzi = lfilter(self._aa_b, self._aa_a, x, zi=state.pos_zi)
        hist = np.concatenate([state.skew_buf, f_aa])
        pos = np.arange(state.skew_buf.size, hist.size) - self._skew
        sensed = np.interp(pos, np.arange(hist.size), hist)
        new = PlantState(
            y=np.asarray(ys[:, -1], float),
            t_s=float(t[-1]),
            x_m=float(x[-1]),
            v_m_s=float(v[-1]),
            force_zi=np.asarray(fzi, float),
            pos_zi=np.asarray(xzi, float),
            skew_buf=hist[-state.skew_buf.size :],
        )
        return force, sensed, np.asarray(x_aa, float), ys[7].copy(), new


@dataclass(frozen=True)
class PlantTruth:
    """What the plant did, per sweep: the physics it actually showed (a release pressure
    the chamber never reached made no vapour)."""

    max_vapour_m3: float
    oil_temperature_c: tuple[float, float]  # at the first and the last measured sample
    lowest_rebound_pa: float


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
) -> tuple[list[Any], PlantTruth]:
    """A click sweep of the reference plant as a rig would record it, offline (no sockets:
    for benchmarks, where a stiff solver is slower than a sim-rig's real time): tests in
    order on one damper, its state (and its heat) carried from test to test, a rest at
    mid-stroke between tests, warm-up cycles not kept. Returns TestData and the truth."""
    from shockdyno.record.types import TestData, TestMeta

    rng = np.random.default_rng(seed)
    plant = ReferencePlant(spec, params, sample_rate_hz)
    state = plant.initial(0.0, ambient_c)
    dt = 1.0 / sample_rate_hz
    clock = 0.0
    tests: list[Any] = []
    vapour, lowest, temps = 0.0, math.inf, []
    last_x = 0.0  # the rod is moved, never set: a jump would move no oil

    def advance(
        x: FloatArray, v: FloatArray, a: FloatArray, areas: tuple[float, float]
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        nonlocal state, clock, vapour, lowest
        t = clock + dt * (1 + np.arange(x.size))
        out = []
        for lo in range(0, x.size, 2000):
            s = slice(lo, lo + 2000)
            got = plant.run(
                np.asarray(t[s], dtype=float), x[s], v[s], a[s], areas, state, ambient_c
            )
            state = got[4]
            out.append(got[:4])
            vapour = max(vapour, float(state.y[4]))
            lowest = min(lowest, float(state.y[0]))
        clock = float(t[-1])
        return tuple(np.concatenate([o[i] for o in out]) for i in range(4))  # type: ignore[return-value]

    for c in clicks:
        bc, bt = spec.bleed_areas(c, 0)
        areas = (float(bc), float(bt))
        for f in frequencies_hz:
            if last_x != 0.0:  # back to mid-stroke (the last test ended at the bottom)
                s = np.arange(1, round(sample_rate_hz) + 1) * dt  # 1 s half-cosine move
                move = last_x * (1 + np.cos(math.pi * s)) / 2
                move_v = -last_x * math.pi / 2 * np.sin(math.pi * s)
                move_a = -last_x * math.pi**2 / 2 * np.cos(math.pi * s)
                advance(move, move_v, move_a, areas)
            rest = np.zeros(round(rest_s * sample_rate_hz))
            advance(rest, rest, rest, areas)
            w = 2 * math.pi * f
            n_warm = round((warmup_cycles + 0.75) / f * sample_rate_hz)
            n = round(cycles / f * sample_rate_hz)
            k = np.arange(n_warm + n + 1) * dt
            # The ram starts from rest: a half-cosine ramp of the amplitude over the first
            # warm-up cycle, so nothing jerks.
            ramp = np.where(k < 1 / f, 0.5 - 0.5 * np.cos(math.pi * k * f), 1.0)
            x = amplitude_m * ramp * np.sin(w * k)
            v = np.gradient(x, dt)
            a = np.gradient(v, dt)
            vapour = 0.0 if not tests else vapour
            _, f_s, x_s, temp = advance(x, v, a, areas)
            last_x = float(x[-1])
            # Kept from the bottom of the stroke: a rig's recording starts anywhere but
            # exactly on a cycle's own up-crossing.
            first = n_warm
            keep = slice(first, first + n + 1)
            temps.append(float(state.y[6]))
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
    truth = PlantTruth(vapour, (temps[0], temps[-1]), lowest)
    return tests, truth
