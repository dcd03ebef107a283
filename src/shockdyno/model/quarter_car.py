"""Quarter car (the paper's eq. 18-19) with a nonlinear damper, many runs integrated at once.

Coordinates: z_s (body) and z_u (wheel) up from static equilibrium, z_r the road under
the tyre. The damper stroke is x = z_u - z_s: x > 0 is compression (the wheel moves up
towards the body), v = dx/dt, and the damper force F(x, v, ẍ) > 0 resists compression,
pushing the body up and the wheel down, the project's convention. Then

    m_s z̈_s =  k_s x + F                                  (eq. 19)
    m_u z̈_u = -k_s x - F + k_t (z_r - z_u)                (eq. 18, with m_u for the text's m_n)

The damper model's force at rest, F(0, 0, 0) (the gas force on the rod, ~230 N for the
default spec), is part of the static balance with the spring preload and weight, like the
weight itself, so it is subtracted: the suspension force is F(x, v, ẍ) - F(0, 0, 0).
The gas spring's rise with stroke stays in.

The model's force is linear in the rod acceleration (rod and gas-piston inertia, m_e ẍ
with m_e ≈ 0.45 kg). In the car ẍ = z̈_u - z̈_s, so the inertia couples the two
equations; we solve that 2×2 linear system in closed form each stage instead of lagging
the acceleration (no algebraic loop, no iteration).

Speed: the model's force costs ~150 µs per call whatever the array size (an iterative
flow solve), and an explicit step needs four calls. `TabulatedDamper` evaluates the
model once, on grids, at build time. The proposed model (without extra physics terms)
is separable, F(x, v, a) = G(x) + H(v) + m_e a (the gas force depends on x, the
pressure drop and friction on v), so two 1-D tables per click hold it; `table_error`
checks the sum against the full model at random points, and the build refuses a table
whose error exceeds its tolerance (a model with a term that breaks separability).
H's grid is uniform in asinh(v / v_s): dense near v = 0, where the smoothed friction
turns over within ~1 mm/s, and coarser at high speed where the force is smooth.

Integration: classical RK4 at a fixed step over every run at once (state arrays of
shape (4, n_runs)). The tyre mode (~11 Hz) is not stiff at a 1 ms step; the stiffest
element is the damper's steepest slope dF/dv (~50 kN·s/m where the rebound valve
cracks, and the friction's 35 N / 1 mm/s), a real eigenvalue of ~1000 s⁻¹ on the
~54 kg reduced mass; `stable_step` reports RK4's bound for it, and the study checks the
step by repeating runs at half the step.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shockdyno.errors import ConfigError
from shockdyno.model.composite import DamperModel, ModelInputs
from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]

RK4_REAL_AXIS_LIMIT = 2.785  # |λ dt| of RK4's stability region on the negative real axis


@dataclass(frozen=True)
class QuarterCar:
    """Table 5 of the paper."""

    sprung_mass_kg: float = 500.0
    unsprung_mass_kg: float = 60.0
    spring_n_m: float = 60_000.0
    tyre_n_m: float = 220_000.0

    def validate(self) -> None:
        """Raise ConfigError unless every mass and stiffness is finite and > 0."""
        for f in fields(self):
            value = getattr(self, f.name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"quarter car: {f.name} must be > 0, got {value}")

    @property
    def wheel_hop_hz(self) -> float:
        """The wheel-hop frequency (Hz): the unsprung mass on spring and tyre in parallel, body
        held."""
        return math.sqrt((self.spring_n_m + self.tyre_n_m) / self.unsprung_mass_kg) / (2 * math.pi)

    @property
    def body_hz(self) -> float:
        """The body's natural frequency (Hz): the sprung mass on spring and tyre in series."""
        k = self.spring_n_m * self.tyre_n_m / (self.spring_n_m + self.tyre_n_m)
        return math.sqrt(k / self.sprung_mass_kg) / (2 * math.pi)


class SuspensionDamper(Protocol):
    """Damper force across the suspension for each run: F(x, v) + m_e ẍ."""

    @property
    def added_mass_kg(self) -> float:
        """m_e (kg): the rod and gas-piston inertia that couples body and wheel accelerations."""

    def force(self, x: FloatArray, v: FloatArray) -> FloatArray:
        """The suspension force (N, positive resisting compression) per run at stroke x (m) and
        velocity v (m/s), less the force at rest, without the m_e ẍ part."""


@dataclass(frozen=True)
class LinearDamper:
    """F = c v per run (c may differ per run); for checks against linear theory."""

    c_ns_m: FloatArray
    added_mass_kg: float = 0.0

    def force(self, x: FloatArray, v: FloatArray) -> FloatArray:
        """c v (N) per run; x is not used."""
        return np.asarray(self.c_ns_m * v, dtype=float)

    @property
    def max_slope_ns_m(self) -> float:
        """The largest c (N·s/m) of the runs: the stiffest slope, for `stable_step`."""
        return float(np.max(self.c_ns_m))


class TabulatedDamper:
    """The damper model per run, from per-click tables G(x) + H(v) (see module doc)."""

    def __init__(
        self,
        spec: DamperSpec | DamperModel,
        areas: Sequence[tuple[float, float]],
        run_table: ArrayLike,
        x_max_m: float = 0.35,
        v_max_m_s: float = 5.0,
        v_scale_m_s: float = 2e-4,
        n_x: int = 2001,
        n_v: int = 16001,
        tolerance_n: float = 2.0,
        tolerance_rel: float = 0.002,
    ) -> None:
        if not areas:
            raise ConfigError("no damper setting to tabulate")
        model = spec.vehicle() if isinstance(spec, DamperModel) else DamperModel(spec)
        self.model = model
        spec = model.spec
        if x_max_m >= 0.95 * spec.max_travel_m:
            raise ConfigError(
                f"stroke table ±{x_max_m} m reaches the gas chamber's limit "
                f"({spec.max_travel_m:.3f} m)"
            )
        self.spec = spec
        self.areas = [(float(a), float(b)) for a, b in areas]
        self.run_table = np.asarray(run_table, dtype=np.int64)
        if self.run_table.size and (
            self.run_table.min() < 0 or self.run_table.max() >= len(self.areas)
        ):
            raise ConfigError("run_table indexes a damper setting that does not exist")
        self.x_max_m = x_max_m
        self.v_max_m_s = v_max_m_s
        self._inv_vs = 1.0 / v_scale_m_s
        self._x_lo = -x_max_m
        self._inv_dx = (n_x - 1) / (2 * x_max_m)
        u_max = math.asinh(v_max_m_s / v_scale_m_s)
        self._u_lo = -u_max
        self._inv_du = (n_v - 1) / (2 * u_max)
        self._n_x, self._n_v = n_x, n_v
        x_grid = np.linspace(-x_max_m, x_max_m, n_x)
        v_grid = v_scale_m_s * np.sinh(np.linspace(-u_max, u_max, n_v))
        g_rows, h_rows, masses = [], [], []
        for a_bc, a_bt in self.areas:
            f0 = _at(model, 0.0, a_bc, a_bt)
            masses.append(_at(model, 1.0, a_bc, a_bt) - f0)
            g_rows.append(quasi_static_force(model, x_grid, 0.0, 0.0, a_bc, a_bt) - f0)
            h_rows.append(quasi_static_force(model, np.zeros(n_v), v_grid, 0.0, a_bc, a_bt) - f0)
        if max(masses) - min(masses) > 1e-9:
            raise ConfigError("damper settings disagree on the moving mass; cannot tabulate")
        self.added_mass_kg = masses[0]
        self.force_at_rest_n = _at(model, 0.0, *self.areas[0])
        g, h = np.array(g_rows), np.array(h_rows)
        self.x_grid, self.v_grid = x_grid, v_grid
        self.g_table, self.h_table = g, h
        # Value and slope per cell, flattened so one gather serves runs of different clicks.
        self._g = g[:, :-1].ravel()
        self._dg = np.diff(g, axis=1).ravel()
        self._h = h[:, :-1].ravel()
        self._dh = np.diff(h, axis=1).ravel()
        self._g_off = self.run_table * (n_x - 1)
        self._h_off = self.run_table * (n_v - 1)
        self.max_error_n, worst = self.table_error(tolerance_n, tolerance_rel)
        if worst > 1.0:
            raise ConfigError(
                f"damper table misses the model by up to {self.max_error_n:.3g} N "
                f"(allowed {tolerance_n} N + {tolerance_rel:.1%} of the force): "
                "is the model separable in x and v?"
            )

    def for_runs(self, run_table: ArrayLike) -> TabulatedDamper:
        """The same tables serving another set of runs (no rebuild)."""
        other = copy.copy(self)
        other.run_table = np.asarray(run_table, dtype=np.int64)
        other._g_off = other.run_table * (self._n_x - 1)
        other._h_off = other.run_table * (self._n_v - 1)
        return other

    def force(self, x: FloatArray, v: FloatArray) -> FloatArray:
        """Suspension force without the inertia part, per run."""
        # Beyond the table the end cell's line extends (clamped index); the study flags
        # runs that leave the table. ufuncs with out= instead of np.clip: this runs
        # four times per step and np.clip's wrapper costs more than the arithmetic.
        p = (x - self._x_lo) * self._inv_dx
        i = np.minimum(np.maximum(p, 0.0), self._n_x - 2.0).astype(np.int64)
        p -= i
        i += self._g_off
        u = np.arcsinh(v * self._inv_vs)
        u -= self._u_lo
        u *= self._inv_du
        k = np.minimum(np.maximum(u, 0.0), self._n_v - 2.0).astype(np.int64)
        u -= k
        k += self._h_off
        f = self._dg[i] * p
        f += self._g[i]
        f += self._h[k]
        f += self._dh[k] * u
        return f

    def table_force(self, setting: int, x: ArrayLike, v: ArrayLike, a: ArrayLike) -> FloatArray:
        """The table's total force (with inertia and the rest force) for one setting."""
        xs, vs, acc = np.broadcast_arrays(
            np.asarray(x, dtype=float), np.asarray(v, dtype=float), np.asarray(a, dtype=float)
        )
        g = np.interp(xs, self.x_grid, self.g_table[setting])
        h = np.interp(vs, self.v_grid, self.h_table[setting])
        return np.asarray(g + h + self.added_mass_kg * acc + self.force_at_rest_n, dtype=float)

    def table_error(
        self, tol_n: float, tol_rel: float, n: int = 20_000, seed: int = 0
    ) -> tuple[float, float]:
        """Largest |table - full model| (N) at random (x, v, a) in the table's range, and
        the largest error relative to the allowance tol_n + tol_rel |F| (> 1: too large).

        Half the velocities are drawn within ±0.5 m/s (the range roads drive), half over
        the whole table, so the dense and the sparse parts are both checked.
        """
        rng = np.random.default_rng(seed)
        worst = 0.0
        worst_ratio = 0.0
        for s, (a_bc, a_bt) in enumerate(self.areas):
            x = rng.uniform(-self.x_max_m, self.x_max_m, n)
            v = np.concatenate(
                [
                    rng.uniform(-0.5, 0.5, n // 2),
                    rng.uniform(-self.v_max_m_s, self.v_max_m_s, n - n // 2),
                ]
            )
            a = rng.uniform(-200.0, 200.0, n)
            full = quasi_static_force(self.model, x, v, a, a_bc, a_bt)
            err = np.abs(full - self.table_force(s, x, v, a))
            worst = max(worst, float(np.max(err)))
            allowed = tol_n + tol_rel * np.abs(full - self.force_at_rest_n)
            worst_ratio = max(worst_ratio, float(np.max(err / allowed)))
        return worst, worst_ratio

    @property
    def max_slope_ns_m(self) -> float:
        """Steepest dF/dv of any table: sets the explicit step's stability limit."""
        return float(np.max(np.diff(self.h_table, axis=1) / np.diff(self.v_grid)))


def quasi_static_force(
    model: DamperModel, x: ArrayLike, v: ArrayLike, a: ArrayLike, a_bc: float, a_bt: float
) -> FloatArray:
    """The model's force with every sample its own segment: lags at their steady state.

    A table point is a state, not a time series; stateful terms (compressibility) give
    their quasi-static force here, and `DamperModel.vehicle` holds the oil at the
    reference temperature (docs/ride.md).
    """
    xs, vs, acc = np.broadcast_arrays(
        np.atleast_1d(np.asarray(x, dtype=float)),
        np.asarray(v, dtype=float),
        np.asarray(a, dtype=float),
    )
    if not model.terms:
        return model.force(ModelInputs.single(xs, vs, acc), a_bc, a_bt)
    return model.force(ModelInputs.points(xs, vs, acc), a_bc, a_bt)


def _at(model: DamperModel, accel: float, a_bc: float, a_bt: float) -> float:
    """The model's force at x = v = 0 and rod acceleration `accel`."""
    return float(np.ravel(quasi_static_force(model, [0.0], [0.0], [accel], a_bc, a_bt))[0])


@dataclass(frozen=True)
class Trajectory:
    """Per run (rows) and time sample (columns), after the warm-up, at t_k = k dt."""

    dt_s: float
    sprung_accel_m_s2: FloatArray
    stroke_m: FloatArray
    stroke_velocity_m_s: FloatArray
    tyre_deflection_m: FloatArray

    @property
    def time_s(self) -> FloatArray:
        """The time of each column (s), from 0 at the end of the warm-up."""
        return np.arange(self.sprung_accel_m_s2.shape[1], dtype=float) * self.dt_s


def stable_step(car: QuarterCar, max_slope_ns_m: float, added_mass_kg: float = 0.0) -> float:
    """RK4's step limit for the damper's steepest slope on the reduced mass (s)."""
    ms, mu = car.sprung_mass_kg + added_mass_kg, car.unsprung_mass_kg + added_mass_kg
    reduced = (ms * mu - added_mass_kg**2) / (ms + mu - 2 * added_mass_kg)
    lam_damper = max_slope_ns_m / reduced
    lam_tyre = 2 * math.pi * car.wheel_hop_hz  # imaginary-axis limit of RK4 is 2.83
    return min(RK4_REAL_AXIS_LIMIT / max(lam_damper, 1e-12), 2.83 / lam_tyre)


def simulate(
    car: QuarterCar,
    damper: SuspensionDamper,
    road_half_steps: FloatArray,
    dt_s: float,
    n_warmup: int,
    start_c_ns_m: ArrayLike = 1500.0,
) -> Trajectory:
    """RK4 over all runs at once on periodic roads.

    road_half_steps has shape (n_runs, 2 n) and holds each run's road at t = k dt / 2
    over one period T = n dt (RK4's middle stages need the half steps). The record covers
    exactly one period after n_warmup steps of warm-up (the road wraps around), so a DFT
    of the record sees whole periods of every road harmonic.

    The runs start from the periodic steady state of a linear car with damper
    start_c_ns_m (per run or one for all): exact for a linear damper of that rate, and
    close enough for the nonlinear damper that the warm-up only has to remove the
    difference, not a start from rest.
    """
    car.validate()
    if dt_s <= 0 or not math.isfinite(dt_s):
        raise ConfigError(f"time step must be > 0, got {dt_s}")
    road = np.ascontiguousarray(np.asarray(road_half_steps, dtype=float).T)  # rows = time
    n_half, n_runs = road.shape
    if n_half % 2:
        raise ConfigError("the road must hold an even number of half steps")
    n = n_half // 2
    me = damper.added_mass_kg
    ms, mu = car.sprung_mass_kg + me, car.unsprung_mass_kg + me
    det = ms * mu - me * me
    c_sp, c_sq, c_up, c_uq = mu / det, me / det, me / det, ms / det
    ks, kt = car.spring_n_m, car.tyre_n_m

    def deriv(y: FloatArray, zr: FloatArray) -> FloatArray:
        x = y[2] - y[0]
        p = ks * x + damper.force(x, y[3] - y[1])
        q = kt * (zr - y[2]) - p
        out = np.empty_like(y)
        out[0] = y[1]
        out[1] = c_sp * p + c_sq * q
        out[2] = y[3]
        out[3] = c_up * p + c_uq * q
        return out

    start = (-2 * n_warmup) % n_half
    y = linear_steady_state(car, start_c_ns_m, road, dt_s / 2, start)
    acc = np.empty((n, n_runs))
    stroke = np.empty((n, n_runs))
    rate = np.empty((n, n_runs))
    tyre = np.empty((n, n_runs))
    h, h2, h6 = dt_s, dt_s / 2, dt_s / 6
    idx = start
    # A step past RK4's stability grows without bound: let it overflow quietly and
    # stop at the next check instead of warning on every step.
    with np.errstate(over="ignore", invalid="ignore"):
        for step in range(n_warmup + n):
            if step % 512 == 0 and not np.all(np.isfinite(y)):
                break
            r0, r1 = road[idx], road[(idx + 1) % n_half]
            idx = (idx + 2) % n_half
            r2 = road[idx]
            k1 = deriv(y, r0)
            k2 = deriv(y + h2 * k1, r1)
            k3 = deriv(y + h2 * k2, r1)
            k4 = deriv(y + h * k3, r2)
            rec = step - n_warmup
            if rec >= 0:
                acc[rec] = k1[1]
                stroke[rec] = y[2] - y[0]
                rate[rec] = y[3] - y[1]
                tyre[rec] = y[2] - r0
            y = y + h6 * (k1 + 2 * (k2 + k3) + k4)
    if not np.all(np.isfinite(y)):
        raise ConfigError(f"the integration diverged at dt = {dt_s} s: use a smaller step")
    return Trajectory(dt_s, acc.T.copy(), stroke.T.copy(), rate.T.copy(), tyre.T.copy())


def _displacement_transfer(
    car: QuarterCar, c_ns_m: FloatArray, s: NDArray[np.complex128]
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """(Z_s / Z_r, Z_u / Z_r) of the linear car at Laplace variable s (broadcasts)."""
    ms, mu, ks, kt = car.sprung_mass_kg, car.unsprung_mass_kg, car.spring_n_m, car.tyre_n_m
    susp = ks + c_ns_m * s
    # [ms s² + susp, -susp; -susp, mu s² + susp + kt] [Zs; Zu] = [0; kt Zr]
    a11, a12, a22 = ms * s**2 + susp, -susp, mu * s**2 + susp + kt
    det = a11 * a22 - a12 * a12
    return -a12 * kt / det, a11 * kt / det


def linear_steady_state(
    car: QuarterCar, c_ns_m: ArrayLike, road: FloatArray, dt_s: float, index: int
) -> FloatArray:
    """State (z_s, ż_s, z_u, ż_u) of the linear car's periodic response at sample `index`.

    road has shape (n_samples, n_runs), one period per column at spacing dt_s.
    """
    n, n_runs = road.shape
    c = np.broadcast_to(np.asarray(c_ns_m, dtype=float), (n_runs,))
    zr = np.fft.rfft(road, axis=0)
    zr[0] = 0.0  # a constant road height moves both masses with it: no state change
    # Only lines that carry road content matter (a band-limited road has few).
    lines = np.flatnonzero(np.max(np.abs(zr), axis=1) > 1e-12 * np.max(np.abs(zr)))
    z = zr[lines] * np.exp(2j * np.pi * lines * index / n)[:, None]
    s = (2j * np.pi * lines / (n * dt_s))[:, None]
    hs, hu = _displacement_transfer(car, c[None, :], s)
    # x_index = (1/n) Σ_all-lines = (2/n) Re Σ_one-sided (no DC, Nyquist assumed empty)
    parts = (hs * z, s * hs * z, hu * z, s * hu * z)
    return np.array([2 / n * np.real(np.sum(p, axis=0)) for p in parts])


def accel_transfer(car: QuarterCar, c_ns_m: float, omega_rad_s: ArrayLike) -> FloatArray:
    """|Z̈_s / Z_r|(ω) of the linear car with damper c: the analytic check of `simulate`."""
    s = 1j * np.asarray(omega_rad_s, dtype=float)
    hs, _ = _displacement_transfer(car, np.asarray(c_ns_m, dtype=float), s)
    return np.asarray(np.abs(s**2 * hs), dtype=float)
