"""The fit's samples, stacked: one model call evaluates every test of the sweep at once.

Each test is a segment of the model's inputs with its own sample step, so stateful terms
filter each test from its own steady state. Each click setting (rod clicks, gas clicks)
is a group with its own bleed areas. A sample moving in compression (v > 0, the velocity
the damper sees after any sensor delay) sees only A_bc, one in rebound only A_bt, so
the areas of different groups and directions touch disjoint samples (exactly for the
paper's model; to within a lag's memory near reversal with stateful terms). "Problems"
index those disjoint sets: problem g is group g's compression samples, n_groups + g its
rebound samples.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.fit.prepare import ClickKey, PreparedTest
from shockdyno.model.composite import DamperModel, ModelInputs
from shockdyno.model.spec import DamperSpec
from shockdyno.record.types import PERIODIC_MOTIONS

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]
SPECS_KEPT = 32  # spec_with's: a Jacobian asks for 1 + one per global


def full_step(p: PreparedTest, max_rate_hz: float | None) -> int:
    """Samples per "full-rate" step: 1, or with a rate cap the largest divisor of the
    objective's step that keeps at least max_rate_hz (so objective samples stay on it)."""
    if max_rate_hz is None or p.obj.size < 2:
        return 1
    k, o = int(p.obj[1] - p.obj[0]), int(p.obj[0])
    fs = 1.0 / float(p.data.t[1] - p.data.t[0])
    ok = [d for d in range(1, k + 1) if k % d == 0 and o % d == 0 and fs / d >= max_rate_hz - 1e-9]
    return max(ok, default=1)  # a recording slower than the cap: every sample


def prepared_inputs(
    tests: Sequence[PreparedTest], full_rate: bool = False, max_rate_hz: float | None = None
) -> ModelInputs:
    """Model inputs of the tests: their objective samples (or every sample, or every
    sample at up to `max_rate_hz`), one segment each."""
    parts = []
    for p in tests:
        d = p.data
        fstep = full_step(p, max_rate_hz)
        idx = np.arange(0, d.t.size, fstep) if full_rate else p.obj
        step = fstep if full_rate or idx.size < 2 else int(idx[1] - idx[0])
        dt = float(d.t[1] - d.t[0]) * step
        temp = None if d.temperature is None else np.asarray(d.temperature[idx], dtype=float)
        gas = None
        if d.meta.gas_pressure_pa is not None:
            gas = np.array([float(d.meta.gas_pressure_pa)])
        parts.append(
            ModelInputs(
                x=np.ascontiguousarray(d.x[idx]),
                v=np.ascontiguousarray(p.v[idx]),
                a=np.ascontiguousarray(p.a[idx]),
                starts=np.zeros(1, dtype=np.intp),
                dt_s=np.array([dt]),
                temperature_c=temp,
                gas_pressure_pa=gas,
                # A sine's or a constant-velocity test's measured cycles follow warm-up
                # cycles: periodic.
                periodic=d.meta.motion in PERIODIC_MOTIONS,
            )
        )
    return ModelInputs.stack(parts)


@dataclass
class Counts:
    """Model evaluations and samples evaluated, shared by a problem and every copy of it
    (a count of work done, not state the result depends on)."""

    evaluations: int = 0
    samples_evaluated: int = 0


class StackedProblem:
    """All objective samples of a sweep, grouped by click setting, for one model.

    Immutable: built from the tests, a base spec (where calibrated globals start, and
    what they apply to) and a model, whose motion stage (a sensor delay) decides the
    compression / rebound split of the samples and whose free parameters decide whether
    it runs at the full rate. `for_model` and `with_base` give new problems that share
    the samples.
    """

    full_rate: bool
    v: FloatArray
    comp: NDArray[np.bool_]
    problem: IntArray

    def __init__(
        self,
        base: DamperSpec,
        tests: Sequence[PreparedTest],
        full_rate_hz: float | None = None,
    ) -> None:
        self.base = base
        self.keys: list[ClickKey] = sorted({p.key for p in tests})
        index = {k: i for i, k in enumerate(self.keys)}
        self.inputs = prepared_inputs(tests)
        # Models with fast lags run on every sample, then give the objective's samples.
        # (at up to full_rate_hz: the diagnosis trades a little accuracy for speed).
        self.full_inputs = prepared_inputs(tests, full_rate=True, max_rate_hz=full_rate_hz)
        steps = [full_step(p, full_rate_hz) for p in tests]
        sizes = [-(-p.data.t.size // k) for p, k in zip(tests, steps, strict=True)]
        offsets = np.cumsum([0, *sizes[:-1]])
        self.obj_in_full: IntArray = np.concatenate(
            [p.obj // k + o for p, k, o in zip(tests, steps, offsets, strict=True)]
        ).astype(np.intp)
        self.full_group: IntArray = np.concatenate(
            [np.full(n, index[p.key], dtype=np.intp) for p, n in zip(tests, sizes, strict=True)]
        )
        # Each full-rate sample's objective sample: the one at or before it in its test.
        seg = self.full_inputs.segment_of_sample()
        pos = np.searchsorted(self.obj_in_full, np.arange(self.full_inputs.size), side="right") - 1
        self.full_to_obj: IntArray = np.maximum(pos, self.inputs.starts[seg]).astype(np.intp)
        self.f = np.concatenate([p.data.force[p.obj] for p in tests])
        self.group: IntArray = np.concatenate(
            [np.full(p.obj.size, index[p.key], dtype=np.intp) for p in tests]
        )
        self.test_id: IntArray = np.concatenate(
            [np.full(p.obj.size, i, dtype=np.intp) for i, p in enumerate(tests)]
        )
        self.counts = Counts()
        self._specs: dict[tuple[tuple[str, ...], bytes], DamperSpec] = {}  # spec_with's
        self._bind(DamperModel(base), ())
        self._frozen = True

    def __setattr__(self, name: str, value: object) -> None:
        if getattr(self, "_frozen", False):
            raise AttributeError(f"StackedProblem is immutable (for_model, with_base): {name}")
        object.__setattr__(self, name, value)

    def _bind(self, model: DamperModel, free: Sequence[str]) -> None:
        full_rate = model.needs_full_rate(free)
        n = len(self.keys)
        _, v, _ = model.motion(self.inputs)
        comp = v > 0
        # Problem id per sample; samples at v == 0 exactly belong to neither (id 2n).
        problem = np.where(comp, self.group, np.where(v < 0, self.group + n, 2 * n))
        object.__setattr__(self, "full_rate", full_rate)
        object.__setattr__(self, "v", v)
        object.__setattr__(self, "comp", comp)
        object.__setattr__(self, "problem", problem.astype(np.intp))

    def for_model(self, model: DamperModel, free: Sequence[str] = ()) -> StackedProblem:
        """The same samples for `model`: its motion splits them, and (with `free`
        varied) it may need the full rate."""
        new = copy.copy(self)
        new._bind(model, free)
        return new

    def with_base(self, base: DamperSpec) -> StackedProblem:
        """The same samples and model with the globals starting from (and applied to)
        `base`."""
        new = copy.copy(self)
        object.__setattr__(new, "base", base)
        object.__setattr__(new, "_specs", {})  # specs of the old base
        return new

    @property
    def evaluations(self) -> int:
        return self.counts.evaluations

    @property
    def samples_evaluated(self) -> int:
        return self.counts.samples_evaluated

    def count(self, samples: int) -> None:
        """One model evaluation over `samples` samples (by this problem or a caller)."""
        self.counts.evaluations += 1
        self.counts.samples_evaluated += samples

    @property
    def n_groups(self) -> int:
        return len(self.keys)

    @property
    def size(self) -> int:
        return int(self.inputs.size)

    def spec_with(self, overrides: dict[str, float]) -> DamperSpec:
        """The base with these globals. A Jacobian's term and area columns, and a point
        evaluated again, ask for the spec of the same globals: the last few are kept,
        matched by name and bits (-0.0 is not 0.0, nor one NaN another), and given back
        as the same spec (whose valves keep their cached stiffness)."""
        if not overrides:
            return self.base
        bits = np.fromiter(overrides.values(), dtype=float, count=len(overrides)).tobytes()
        key = (tuple(overrides), bits)
        spec = self._specs.get(key)
        if spec is None:
            spec = self.base.with_values(overrides)
            self._specs[key] = spec
            if len(self._specs) > SPECS_KEPT:
                del self._specs[next(iter(self._specs))]  # the oldest
        return spec

    def force(
        self, model: DamperModel | DamperSpec, a_bc: FloatArray, a_bt: FloatArray
    ) -> FloatArray:
        """Model force on every sample; a_bc and a_bt are per group (or per sample)."""
        m = model if isinstance(model, DamperModel) else DamperModel(model)
        per_group = a_bc.size == self.n_groups
        if not self.full_rate:
            self.count(self.size)
            if per_group:
                return m.force(self.inputs, a_bc[self.group], a_bt[self.group])
            return m.force(self.inputs, a_bc, a_bt)
        self.count(self.full_inputs.size)
        if per_group:
            bc, bt = a_bc[self.full_group], a_bt[self.full_group]
        else:
            bc, bt = self.to_full(a_bc), self.to_full(a_bt)
        return m.force(self.full_inputs, bc, bt)[self.obj_in_full]

    def to_full(self, per_obj: FloatArray) -> FloatArray:
        """Per-objective-sample values spread over every sample: each sample takes the
        value of the objective sample at or before it in its test."""
        return per_obj[self.full_to_obj]

    def per_problem(self, values: FloatArray) -> FloatArray:
        """Sum of a per-sample quantity over each of the 2 n_groups problems."""
        n = 2 * self.n_groups
        return np.bincount(self.problem, weights=values, minlength=n + 1)[:n].astype(float)

    def per_group(self, values: FloatArray) -> FloatArray:
        return np.bincount(self.group, weights=values, minlength=self.n_groups).astype(float)
