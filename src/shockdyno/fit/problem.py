"""The fit's samples, stacked: one model call evaluates every test of the sweep at once.

Each click setting (rod clicks, gas clicks) is a group with its own bleed areas. A sample
moving in compression (v > 0) sees only A_bc, one in rebound only A_bt (the model picks
the area by the sign of the flow, which is the sign of v), so the areas of different
groups and directions touch disjoint samples. "Problems" index those disjoint sets:
problem g is group g's compression samples, n_groups + g its rebound samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.fit.prepare import PreparedTest
from shockdyno.fit.result import apply_overrides
from shockdyno.model import damper_force
from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class GlobalParam:
    """A calibrated damper parameter, optimised as value / scale within [lo, hi]."""

    key: str
    scale: float
    lo: float
    hi: float


# Bounds as factors of the nominal value: wide enough for a real damper's departure from
# its drawing, narrow enough to keep the valve physical (no zero face area).
_FACTORS = {
    "gas_pressure_pa": (0.2, 5.0, 1.0e6),
    "friction_n": (0.0, 6.0, 20.0),
    "compression_valve.preload_m": (0.0, 5.0, 1.0e-4),
    "compression_valve.face_area_m2": (0.2, 5.0, 1.0e-4),
    "rebound_valve.preload_m": (0.0, 5.0, 1.0e-4),
    "rebound_valve.face_area_m2": (0.2, 5.0, 1.0e-4),
}
DEFAULT_GLOBALS = tuple(_FACTORS)


def nominal_value(spec: DamperSpec, key: str) -> float:
    head, _, tail = key.partition(".")
    obj = getattr(spec, head)
    return float(getattr(obj, tail) if tail else obj)


def global_params(spec: DamperSpec, keys: Sequence[str] = DEFAULT_GLOBALS) -> list[GlobalParam]:
    out = []
    for key in keys:
        lo, hi, fallback = _FACTORS.get(key, (0.2, 5.0, 1.0))
        nominal = nominal_value(spec, key)
        out.append(GlobalParam(key, nominal if nominal > 0 else fallback, lo, hi))
    return out


# Channel delay: the measured force at sample time t is the damper's response to the
# motion at t - delay (load-cell or LVDT filtering, the DAQ sampling the two channels at
# different instants, a velocity estimated by a backward difference). Calibrated within
# ±5 ms, in ms.
DELAY_SCALE_S = 1e-3
DELAY_BOUND_S = 5e-3


def delayed_motion(
    x: FloatArray, v: FloatArray, a: FloatArray, delay_s: float
) -> tuple[FloatArray, FloatArray]:
    """(x, v) at t - delay, to first order: the omitted terms, δ²/2 times a or the jerk,
    are below 1e-5 m and 1e-4 m/s for δ <= 1 ms on the dyno's sines."""
    if delay_s == 0.0:
        return x, v
    return x - delay_s * v, v - delay_s * a


class StackedProblem:
    """All objective samples of a sweep, grouped by click setting.

    `x`, `v` are the motion the model sees: the measured one shifted by the channel delay
    set with `set_delay`; compression and rebound samples follow the shifted velocity.
    """

    def __init__(self, base: DamperSpec, tests: Sequence[PreparedTest]) -> None:
        self.base = base
        self.keys: list[tuple[int, int]] = sorted({p.key for p in tests})
        index = {k: i for i, k in enumerate(self.keys)}
        self.x_measured = np.concatenate([p.data.x[p.obj] for p in tests])
        self.v_measured = np.concatenate([p.v[p.obj] for p in tests])
        self.a = np.concatenate([p.a[p.obj] for p in tests])
        self.f = np.concatenate([p.data.force[p.obj] for p in tests])
        self.group: IntArray = np.concatenate(
            [np.full(p.obj.size, index[p.key], dtype=np.intp) for p in tests]
        )
        self.test_id: IntArray = np.concatenate(
            [np.full(p.obj.size, i, dtype=np.intp) for i, p in enumerate(tests)]
        )
        self.evaluations = 0
        self.samples_evaluated = 0
        self.set_delay(0.0)

    def set_delay(self, delay_s: float) -> None:
        n = len(self.keys)
        self.delay_s = float(delay_s)
        self.x, self.v = delayed_motion(self.x_measured, self.v_measured, self.a, self.delay_s)
        self.comp = self.v > 0
        # Problem id per sample; samples at v == 0 exactly belong to neither (id 2n).
        self.problem: IntArray = np.where(
            self.comp, self.group, np.where(self.v < 0, self.group + n, 2 * n)
        ).astype(np.intp)

    @property
    def n_groups(self) -> int:
        return len(self.keys)

    @property
    def size(self) -> int:
        return int(self.x.size)

    def spec_with(self, overrides: dict[str, float]) -> DamperSpec:
        return apply_overrides(self.base, overrides) if overrides else self.base

    def force(
        self,
        spec: DamperSpec,
        a_bc: FloatArray,
        a_bt: FloatArray,
        delay_s: float | None = None,
    ) -> FloatArray:
        """Model force on every sample; a_bc and a_bt are per group (or per sample).

        delay_s (else the one set) shifts the motion; the problem ids stay as set.
        """
        bc = a_bc[self.group] if a_bc.size == self.n_groups else a_bc
        bt = a_bt[self.group] if a_bt.size == self.n_groups else a_bt
        self.evaluations += 1
        self.samples_evaluated += self.size
        x, v = self.x, self.v
        if delay_s is not None and delay_s != self.delay_s:
            x, v = delayed_motion(self.x_measured, self.v_measured, self.a, delay_s)
        return damper_force(spec, x, v, self.a, bc, bt)

    def per_problem(self, values: FloatArray) -> FloatArray:
        """Sum of a per-sample quantity over each of the 2 n_groups problems."""
        n = 2 * self.n_groups
        return np.bincount(self.problem, weights=values, minlength=n + 1)[:n].astype(float)

    def per_group(self, values: FloatArray) -> FloatArray:
        return np.bincount(self.group, weights=values, minlength=self.n_groups).astype(float)
