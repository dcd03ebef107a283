"""Effects outside the term library, on the held-out plant (holdout/plant.py, sweep.py).

Each effect is the plant's or the instrument chain's own physics, in a form no library
term has (model/terms) and none of the holdout plant's effects has either. They are
written here as subclasses of the holdout `Plant` and `Daq`, so holdout/ stays as its
authors wrote it; `record_sweep` runs holdout's `run_sweep` with them in place.

Conventions as in holdout/plant.py: x > 0 compression, force > 0 resists compression,
SI, pressures absolute.

drift      load-cell zero drift from the session's start (the bridge and its amplifier
           warming up, heat from the damper reaching the cell):
               F_meas = F + D (1 - exp(-t / τ)),   t from the sweep's first sample.
           A 10 kN cell drifting 0.1-0.25 % of its range over a session (HBM give a zero
           coefficient under 0.05 %/10 K for a good cell; an installed bridge warming by
           25 K drifted 15 N on a 500 N cell, atlasofengineering's case study).
groove     a bypass groove in the pressure tube over part of the stroke (position-sensitive
           damping, the PSD grooves of twin-tube dampers; Tenneco's stroke-dependent
           bypass patents): while the piston band lies over the groove the oil has a
           second orifice path of area A_g(x) in parallel with the bleed and the valves,
               q_g = C_D A_g(x) sqrt(2 |Δp| / ρ) sign(Δp)   (laminar below 100 Pa),
               A_g(x) = A_g clip(min(x - x1, x2 - x) / w, 0, 1),  w = 3 mm (the band
           crossing the groove's ends), so the damping falls over [x1, x2], more on the
           stiffer clicks (the groove is a larger share of their flow area).
sideload   rod-guide friction from a misaligned fixture: the lateral offset between the
           actuator's axis and the damper's loads the rod guide through a bending moment
           that grows as the rod extends (the overhang between guide and eye grows), so a
           Coulomb friction that grows linearly past x_s toward full extension,
               F_side = k_s max(x_s - x, 0) · v / sqrt(v² + v_f²),  v_f = 1 mm/s.
lvdt_play  free play in the displacement transducer's linkage (a worn rod-end or bracket
           between the LVDT's core and the ram): the recorded position is the ram's
           through a play operator of half-width b (it stands still while the ram takes up
           the lash after each reversal), the damper itself driven without play.
valve_hyst friction between the shims of both valves (shim-stack hysteresis): the stack's
           lift trails its static lift (y_s = (|Δp| A_face - F_pre)/k, clipped to [0,
           max lift]) through a play of half-width h: it opens late and closes late,
               y = clip(y_prev, y_s - h, y_s + h),  h: a few µm of a 10-70 µm working lift,
           so above the knee the force is higher while the speed rises and lower while it
           falls, whatever the frequency (rate-independent: no time constant).
fixture    a fixture mass m_f between the load cell and the damper moving with the ram
           (load cell on the actuator side): F_meas = F + m_f ẍ. The library has this one
           as a named term (`inertia`): it is here as a named effect, not an unnamed one.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

import holdout.sweep as holdout_sweep
from holdout.plant import LAMINAR_ORIFICE_PA, Daq, Effects, Plant

FloatArray = NDArray[np.float64]
GROOVE_RAMP_M = 0.003
SIDE_FRICTION_V_M_S = 0.001


@dataclass(frozen=True)
class Unnamed:
    """The strengths of the effects above; each off at its default."""

    drift_n: float = 0.0
    drift_tau_s: float = 150.0
    groove_area_m2: float = 0.0
    groove_lo_m: float = 0.0
    groove_hi_m: float = 0.0
    side_n_per_m: float = 0.0
    side_onset_m: float = 0.0
    lvdt_play_m: float = 0.0
    valve_play_m: float = 0.0
    fixture_kg: float = 0.0

    def names(self) -> list[str]:
        """The effects this plant has, by name."""
        on = {
            "drift": self.drift_n != 0,
            "groove": self.groove_area_m2 > 0,
            "sideload": self.side_n_per_m > 0,
            "lvdt_play": self.lvdt_play_m > 0,
            "valve_hyst": self.valve_play_m > 0,
            "fixture": self.fixture_kg != 0,
        }
        return [k for k, v in on.items() if v]


class UnnamedPlant(Plant):
    """The holdout plant with the damper-side effects (groove, sideload, fixture)."""

    def __init__(self, effects: Effects, extra: Unnamed) -> None:
        self.extra = extra
        self.lift = [0.0, 0.0]  # each valve's lift as the last step left it (valve_hyst)
        super().__init__(effects=effects)
        if extra.valve_play_m > 0 and effects.thermal:
            raise ValueError("valve_hyst is written for a valve with no seat land (no thermal)")

    def _lift(self, d: float, direction: int) -> tuple[float, float]:
        """The valve's lift with the shims' play, and its slope in |Δp| (0 while held)."""
        _, face, k, pre, ymax = self.valves[direction]
        h = self.extra.valve_play_m
        ys = min(max((d * face - pre) / k, 0.0), ymax)
        held = self.lift[direction]
        if ys - h > held:
            return ys - h, (face / k if 0 < ys < ymax else 0.0)
        if ys + h < held:
            return max(ys + h, 0.0), (face / k if 0 < ys < ymax and ys + h > 0 else 0.0)
        return held, 0.0

    def _path(self, d: float, direction: int, mu_ratio: float, land: float) -> tuple[float, float]:
        if self.extra.valve_play_m <= 0:
            return super()._path(d, direction, mu_ratio, land)
        valve = self.valves[direction]
        self.valves[direction] = (*valve[:3], math.inf, valve[4])  # the bleed alone
        try:
            q, dq = super()._path(d, direction, mu_ratio, land)
        finally:
            self.valves[direction] = valve
        y, dy = self._lift(d, direction)
        if y > 0 and d > 0:
            sd = math.sqrt(d)
            q += self.cd_s * valve[0] * y * sd
            dq += self.cd_s * valve[0] * (dy * sd + y / (2.0 * sd))
        return q, dq

    def groove_area(self, x: float) -> float:
        u = self.extra
        if u.groove_area_m2 <= 0:
            return 0.0
        inside = min(x - u.groove_lo_m, u.groove_hi_m - x) / GROOVE_RAMP_M
        return u.groove_area_m2 * min(max(inside, 0.0), 1.0)

    def flow(self, dp: float, v: float, mu: float) -> tuple[float, float]:
        q, dq = super().flow(dp, v, mu)
        area = self.groove_area(self.x)
        if area <= 0:
            return q, dq
        # |Δp| = a q² + β q: an orifice, laminar below LAMINAR_ORIFICE_PA (as the bleed)
        a = 1.0 / (self.cd_s * area) ** 2
        b = math.sqrt(4.0 * a * LAMINAR_ORIFICE_PA)
        d = abs(dp)
        s = math.sqrt(b * b + 4.0 * a * d)
        den = b + s
        qg = 2.0 * d / den
        dqg = 2.0 * (den - 2.0 * a * d / s) / (den * den)
        return q + math.copysign(qg, dp), dq + dqg

    def seal_force(self, dx: float, v: float) -> float:
        f = super().seal_force(dx, v)
        u = self.extra
        if u.side_n_per_m > 0:
            x = self.x + dx  # seal_force is called before x is moved on (Plant.step)
            load = u.side_n_per_m * max(u.side_onset_m - x, 0.0)
            f += load * v / math.sqrt(v * v + SIDE_FRICTION_V_M_S**2)
        return f

    def step(
        self, x_new: float, h: float, v: float = 0.0, xdd: float = 0.0, bdf2: bool = True
    ) -> float:
        force = super().step(x_new, h, v, xdd, bdf2) + self.extra.fixture_kg * xdd
        if self.extra.valve_play_m > 0:  # the lifts the step ended with are held
            dp = self.p_c - self.p_r
            on = 0 if dp >= 0 else 1
            self.lift[on] = self._lift(abs(dp), on)[0]
            self.lift[1 - on] = self._lift(0.0, 1 - on)[0]
        return force


class UnnamedDaq(Daq):
    """The holdout instrument chain with the sensor-side effects (drift, lvdt_play)."""

    def __init__(self, effects: Effects, extra: Unnamed, *args: Any, **kw: Any) -> None:
        super().__init__(effects, *args, **kw)
        self.extra = extra
        self.t_first: float | None = None
        self.core = 0.0  # where the LVDT's core sits within the play (carried test to test)

    def force(self, t: FloatArray, f: FloatArray) -> FloatArray:
        u = self.extra
        if u.drift_n != 0:
            if self.t_first is None:
                self.t_first = float(t[0])
            f = f + u.drift_n * (1.0 - np.exp(-(t - self.t_first) / u.drift_tau_s))
        return super().force(t, f)

    def displacement(self, x: FloatArray) -> FloatArray:
        b = self.extra.lvdt_play_m
        if b > 0:
            x = self._play(x, b)
        return super().displacement(x)

    def _play(self, x: FloatArray, b: float) -> FloatArray:
        out = np.empty_like(x)
        y = self.core
        for i, xi in enumerate(x):
            if xi - y > b:
                y = xi - b
            elif y - xi > b:
                y = xi + b
            out[i] = y
        self.core = y
        return out


@contextmanager
def _patched(extra: Unnamed) -> Iterator[None]:
    """holdout's run_sweep builds its own Plant and Daq: these take their place for a call."""
    plant, daq = holdout_sweep.Plant, holdout_sweep.Daq

    def make_plant(effects: Effects) -> Plant:
        return UnnamedPlant(effects, extra)

    def make_daq(effects: Effects, *args: Any, **kw: Any) -> Daq:
        return UnnamedDaq(effects, extra, *args, **kw)

    holdout_sweep.Plant, holdout_sweep.Daq = make_plant, make_daq  # type: ignore[assignment,misc]
    try:
        yield
    finally:
        holdout_sweep.Plant, holdout_sweep.Daq = plant, daq  # type: ignore[misc]


def record_sweep(
    extra: Unnamed, out_dir: Path | str, seed: int, effects: Effects | None = None, **kw: Any
) -> holdout_sweep.SweepTruth:
    """The holdout sweep of the plant with `extra`, written as CSVs (holdout's format) with
    `unnamed` (the strengths) and `unnamed_effects` (their names) added to truth.json."""
    import json

    with _patched(extra):
        truth, _ = holdout_sweep.run_sweep(effects or Effects(), out_dir, seed=seed, **kw)
    path = Path(out_dir) / "truth.json"
    if path.exists():
        doc = json.loads(path.read_text())
        doc["unnamed"] = asdict(extra)
        doc["unnamed_effects"] = extra.names()
        path.write_text(json.dumps(doc, indent=1) + "\n")
    return truth


# -- cases: strengths drawn per seed (ranges fixed from physics before any diagnosis) -----
Range = tuple[float, float]


@dataclass(frozen=True)
class Case:
    name: str
    ranges: dict[str, Range] = field(default_factory=dict)


CASES = [
    Case("drift", {"drift_n": (12.0, 25.0), "drift_tau_s": (100.0, 250.0)}),
    Case(
        "groove",
        {
            "groove_area_m2": (1.5e-6, 3.0e-6),
            "groove_lo_m": (-0.014, -0.006),
            "groove_hi_m": (0.006, 0.014),
        },
    ),
    Case("sideload", {"side_n_per_m": (0.8e3, 1.5e3), "side_onset_m": (-0.005, 0.010)}),
    Case("lvdt_play", {"lvdt_play_m": (0.15e-3, 0.35e-3)}),
    Case("valve_hyst", {"valve_play_m": (1.5e-6, 4e-6)}),
    Case("fixture", {"fixture_kg": (4.0, 10.0)}),
]
BY_NAME = {c.name: c for c in CASES}


def draw(case: Case, seed: int) -> Unnamed:
    """This case's effect for this seed: every range drawn uniformly."""
    rng = np.random.default_rng([seed, zlib.crc32(case.name.encode())])
    return Unnamed(**{k: float(rng.uniform(*r)) for k, r in sorted(case.ranges.items())})


def noise_seed(name: str, seed: int) -> int:
    return (seed * 1_000_003 + zlib.crc32(("unnamed:" + name).encode())) % (2**31)


def strength_text(u: Unnamed) -> str:
    """The effect's numbers as a dyno engineer would say them."""
    parts = []
    if u.drift_n:
        parts.append(f"zero drift {u.drift_n:.1f} N, τ {u.drift_tau_s:.0f} s")
    if u.groove_area_m2 > 0:
        parts.append(
            f"groove {u.groove_area_m2 * 1e6:.2f} mm² over "
            f"{u.groove_lo_m * 1e3:+.1f}…{u.groove_hi_m * 1e3:+.1f} mm"
        )
    if u.side_n_per_m > 0:
        parts.append(
            f"side-load friction {u.side_n_per_m / 1e3:.2f} N/mm below "
            f"{u.side_onset_m * 1e3:+.1f} mm"
        )
    if u.lvdt_play_m > 0:
        parts.append(f"LVDT play ±{u.lvdt_play_m * 1e3:.2f} mm")
    if u.valve_play_m > 0:
        parts.append(f"shim-stack play ±{u.valve_play_m * 1e6:.1f} µm of lift")
    if u.fixture_kg:
        parts.append(f"fixture mass {u.fixture_kg:.1f} kg")
    return "; ".join(parts)
