"""One damper model: the paper's physics plus any set of declared terms.

`DamperModel(spec, terms, values)` is immutable and is what the simulated rig, the fit,
validation, diagnose, the report and the ride study all evaluate, so a term written once
appears everywhere. A term declares its parameters (`model/params.py`) and a stage; the
model runs the stages in a fixed order, so any set of terms in any order gives the same
force:

    MOTION    (10) the motion the damper sees (sensor delay, LVDT lag)
    CHAMBER   (20) leak conductance and chamber pressure before the flow solve (thermal,
                   gas spring)
    flow solve     Δp for the flow demand (eq. 2-4, 7)
    PRESSURE  (40) pressures after the solve (compressibility, cavitation)
    FORCE     (60) added forces (friction, position force)
    SENSOR    (80) what the load cell reports (load-cell lag)

Within a stage terms run by name. Each term adds its own force component, and the
components sum to the total exactly (`Evaluation.components`).

Inputs are segments (one per test), each with its own sample step; stateful terms
filter each segment from steady state, and a single-segment call may carry state into
the next (`Evaluation.state`), never on the term or the model.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shockdyno.errors import ConfigError
from shockdyno.model.filters import segment_bounds
from shockdyno.model.flow import solve_signed_drop
from shockdyno.model.gas import compression_pressure
from shockdyno.model.params import Param, SpecCalibration
from shockdyno.model.reading import Reading
from shockdyno.model.seal import seal_force
from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

ATMOSPHERE_PA = 101_325.0  # pressures are absolute (the gas law needs it)
MOTION, CHAMBER, FLOW, PRESSURE, FORCE, SENSOR = 10, 20, 30, 40, 60, 80
BASE_COMPONENTS = ("inertia", "gas", "hydraulic", "coulomb")  # never a term's name


@dataclass(frozen=True)
class ModelInputs:
    """Motion per sample, in segments (tests) with their own sample step.

    `temperature_c` is the measured temperature per sample (NaN where unknown; on a rig,
    the body's: the thermal term puts the oil ahead of it);
    `gas_pressure_pa` the measured gas charge per segment, absolute (NaN: unknown).
    `periodic`: every segment is whole cycles of a periodic motion in its steady state
    (a sweep's measured cycles): fast lags start in the state they end in.
    """

    x: FloatArray
    v: FloatArray
    a: FloatArray
    starts: IntArray
    dt_s: FloatArray
    temperature_c: FloatArray | None = None
    gas_pressure_pa: FloatArray | None = None
    periodic: bool = False

    @cached_property
    def channel_temperature(self) -> tuple[FloatArray, FloatArray] | None:
        """The temperature channel per sample, its gaps filled with its segment's mean (NaN
        in a segment with no reading), and each segment's rate of rise per sample (°C/s,
        least squares; 0 with fewer than three readings). None without a channel. Data, not
        parameters: worked out once per inputs, not at every evaluation of the model."""
        measured = self.temperature_c
        if measured is None:
            return None
        filled = np.full(measured.shape, np.nan)
        slope = np.zeros(measured.shape)
        for k, (lo, hi) in enumerate(segment_bounds(self.starts, measured.size)):
            seg = measured[lo:hi]
            ok = np.isfinite(seg)
            if not np.any(ok):
                continue
            filled[lo:hi] = np.where(ok, seg, float(np.mean(seg[ok])))
            if np.count_nonzero(ok) > 2:
                t = np.arange(hi - lo, dtype=float)[ok] * float(self.dt_s[k])
                slope[lo:hi] = float(np.polyfit(t, seg[ok], 1)[0])
        return filled, slope

    @staticmethod
    def single(
        x: ArrayLike,
        v: ArrayLike,
        a: ArrayLike,
        dt_s: float = 1e-3,
        temperature_c: ArrayLike | None = None,
    ) -> ModelInputs:
        """One test as one segment: displacement `x` (m, compression positive), velocity `v`
        (m/s) and acceleration `a` (m/s²) per sample (a scalar broadcast), at sample step `dt_s`
        (s), with the temperature per sample (°C) if known."""
        xs = np.atleast_1d(np.asarray(x, dtype=float))
        vs, acc = (
            np.ascontiguousarray(np.broadcast_to(np.asarray(u, float), xs.shape)) for u in (v, a)
        )
        temp = None
        if temperature_c is not None:
            temp = np.ascontiguousarray(np.broadcast_to(np.asarray(temperature_c, float), xs.shape))
        return ModelInputs(xs, vs, acc, np.zeros(1, dtype=np.intp), np.array([float(dt_s)]), temp)

    @staticmethod
    def points(
        x: FloatArray, v: FloatArray, a: FloatArray, temperature_c: FloatArray | None = None
    ) -> ModelInputs:
        """Every sample its own segment: states, not a time series (stateful terms sit
        at their steady state); `temperature_c` per sample, or none."""
        n = x.size
        return ModelInputs(
            np.ascontiguousarray(x),
            np.ascontiguousarray(v),
            np.ascontiguousarray(a),
            np.arange(n, dtype=np.intp),
            np.full(n, 1e-3),
            temperature_c=temperature_c,
        )

    @staticmethod
    def stack(parts: Sequence[ModelInputs]) -> ModelInputs:
        """The segments of `parts` one after another, as one input (a part with no temperature or
        gas charge gets NaN for them; periodic only if every part is)."""
        sizes = np.array([p.x.size for p in parts], dtype=np.intp)
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.intp)
        temps = [p.temperature_c for p in parts]
        temp = None
        if any(t is not None for t in temps):
            temp = np.concatenate(
                [
                    t if t is not None else np.full(p.x.size, np.nan)
                    for t, p in zip(temps, parts, strict=True)
                ]
            )
        gases = [p.gas_pressure_pa for p in parts]
        gas = None
        if any(g is not None for g in gases):
            gas = np.concatenate(
                [
                    g if g is not None else np.full(p.starts.size, np.nan)
                    for g, p in zip(gases, parts, strict=True)
                ]
            )
        return ModelInputs(
            x=np.concatenate([p.x for p in parts]),
            v=np.concatenate([p.v for p in parts]),
            a=np.concatenate([p.a for p in parts]),
            starts=np.concatenate([p.starts + o for p, o in zip(parts, offsets, strict=True)]),
            dt_s=np.concatenate([p.dt_s for p in parts]),
            temperature_c=temp,
            gas_pressure_pa=gas,
            periodic=all(p.periodic for p in parts),
        )

    def tile(self, k: int) -> ModelInputs:
        """k copies one after another (the GA scores a population in one call)."""
        return ModelInputs.stack([self] * k)

    @property
    def size(self) -> int:
        return int(self.x.size)

    def segment_of_sample(self) -> IntArray:
        """The index of the segment each sample belongs to."""
        seg = np.zeros(self.size, dtype=np.intp)
        seg[self.starts[1:]] = 1
        return np.cumsum(seg).astype(np.intp)


@dataclass
class Work:
    """The evaluation's scratch: what every stage reads and edits, per sample."""

    spec: DamperSpec
    inputs: ModelInputs
    x: FloatArray
    v: FloatArray
    a: FloatArray
    bleed_compression_m2: FloatArray
    bleed_rebound_m2: FloatArray
    k_leak: FloatArray
    q_demand: FloatArray
    p_c: FloatArray
    # λ = 8π μ L of the bleed's laminar land per sample (spec.bleed_land_m; 0: a sharp
    # orifice); a term that changes the viscosity scales it as it scales k_leak's inverse.
    bleed_laminar: FloatArray = field(default_factory=lambda: np.zeros(0))
    # λ_v = 12 μ L of the shim stacks' seat land per sample (spec.valve_land_m; 0: a
    # sharp-edged opening); scaled with the viscosity as bleed_laminar is.
    valve_laminar: FloatArray = field(default_factory=lambda: np.zeros(0))
    # The gas column per sample (m³) and its polytropic index: a chamber term that takes
    # volume from the oil side (air expanding, vapour) compresses it further.
    gas_volume: FloatArray = field(default_factory=lambda: np.zeros(0))
    gas_index: float = 1.0
    # A factor on the algebraic solve's Δp per sample (a term's, the oil's temperature;
    # empty: 1), which a chamber term's integration applies to its flow law as well.
    dp_scale: FloatArray = field(default_factory=lambda: np.zeros(0))
    p_c_static: FloatArray | None = None  # p_c before any chamber state acted on it
    dp: FloatArray | None = None
    dp_static: FloatArray | None = None  # Δp before any chamber state acted on it
    chamber: Any = None  # model/chamber.Chamber: the compliance a chamber term found
    parts: dict[str, FloatArray] = field(default_factory=dict)
    outputs: dict[str, FloatArray] = field(default_factory=dict)
    total: FloatArray | None = None

    @property
    def starts(self) -> IntArray:
        return self.inputs.starts

    @property
    def dt_s(self) -> FloatArray:
        return self.inputs.dt_s

    def add_part(self, name: str, force: FloatArray) -> None:
        """Add `force` (N, per sample, positive resisting compression) to the force component
        `name`, summing with what it already holds."""
        self.parts[name] = self.parts[name] + force if name in self.parts else force

    def set_dp(self, name: str, dp: FloatArray) -> None:
        """Replace Δp after the solve; the change of hydraulic force is `name`'s part."""
        assert self.dp is not None
        self.add_part(name, (dp - self.dp) * self.spec.annulus_area_m2)
        self.dp = dp

    def set_p_c(self, name: str, p_c: FloatArray) -> None:
        """Replace the compression-chamber pressure; the gas-force change is `name`'s."""
        self.add_part(name, (p_c - self.p_c) * self.spec.rod_area_m2)
        self.p_c = p_c


class Term:
    """A piece of physics (or sensor behaviour) the paper's model leaves out.

    Subclasses set `name`, `stage`, `PARAMS` and implement `apply`. `apply` gets the
    term's parameter values by local name and the state it carried out of the previous
    call (single segment only), and returns the state to carry on (or None).
    """

    name: ClassVar[str]
    stage: ClassVar[int]  # where the term sorts; it runs at each of `stages`
    stages: ClassVar[tuple[int, ...]] = ()
    sensor: ClassVar[bool] = False  # measurement, not damper: left out of the vehicle
    stateful: ClassVar[bool] = False
    PARAMS: ClassVar[tuple[Param, ...]] = ()
    summary: ClassVar[str] = ""  # one line: the words of a term that has no describe of its own
    # What would tell this term from a look-alike, by the look-alike's name: a diagnosis
    # that cannot separate the two says so. Each pair is written on one of its terms.
    separated_by: ClassVar[dict[str, str]] = {}
    # A parameter the diagnosis calibrates as the spec's error before it tries physics.
    calibrates: ClassVar[SpecCalibration | None] = None
    # A generic form for what no named term explains: it competes in the diagnosis's
    # search but is claimed only when no named term is.
    open_set: ClassVar[bool] = False
    # The signals of a recording this term's force follows ("displacement", "velocity",
    # "direction", "acceleration", "temperature", "position": a force past a point of
    # the stroke, "presliding": a turn after each reversal, "lag": the force behind the
    # motion in time). A residual that follows one is this term's physics, and the
    # diagnosis never discovers it as unnamed physics (diagnose/features.py).
    follows: ClassVar[tuple[str, ...]] = ()
    # The parameters that shift the measured force against the measured motion in time,
    # each with its sign: their signed sum is the term's net shift. A sensor's is one
    # time for the whole sweep, which the diagnosis checks (diagnose/consistency.py).
    time_shift: ClassVar[dict[str, float]] = {}
    # Where the term's own force is told apart from what the areas and valves refitted
    # beside it can do: "cycle", a place in each cycle (a stop past its onset, a lag at
    # each reversal), or "session", a scale of the damper's own force that changes from
    # test to test (heat). The diagnosis judges a claim where it is (diagnose/in_place.py).
    place: ClassVar[str] = "cycle"

    def describe(self, r: Reading) -> str:
        """The fitted physics in words, naming only the parameters the data moved (with
        their σ); a term without words of its own lists them."""
        return r.plain(f"{self.name}: {self.summary}")

    def params(self) -> tuple[Param, ...]:
        """The parameters the term declares (`PARAMS`): unit, nominal, bounds, off value."""
        return self.PARAMS

    def qualified(self, local: str) -> str:
        """The parameter's qualified name, `term.local` (`friction.breakaway_n`), as fits and
        JSON name it."""
        return f"{self.name}.{local}"

    def run_stages(self) -> tuple[int, ...]:
        """The stages the term runs at: `stages`, or its one `stage`."""
        return self.stages or (self.stage,)

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        """Act at `stage` on the evaluation's scratch `w`: add a force component (`w.add_part`)
        or change the motion, Δp or the chamber pressure. `p` holds the term's values by local
        name, `carry` the state it carried out of the previous single-segment call (or None);
        returns the state to carry on, or None."""
        raise NotImplementedError

    def penalty(self, p: Mapping[str, float]) -> FloatArray:
        """Extra least-squares residuals (N) that regularise the term (none by default)."""
        return np.zeros(0)

    def vehicle_ok(self) -> bool:
        """Whether the term belongs to the damper on a car (a sensor term does not)."""
        return not self.sensor

    def full_rate(self, p: Mapping[str, float], free: Iterable[str]) -> bool:
        """Whether the term must run at the recording's own rate to be accurate: a lag
        of a few ms on a force that turns in a few ms after reversal cannot be computed
        from the fit's 5 ms samples. `free` are the local names the fit will vary."""
        return self.stateful

    def carries_state(self, p: Mapping[str, float], free: Iterable[str]) -> bool:
        """Whether, at these values (and with `free` varied), a sample's force depends on
        the motion before it, so an area's effect runs on past reversal. A stateful term
        whose state is switched off and held does not (a sensor chain with no lag)."""
        return self.stateful

    def nesting_free(self) -> tuple[str, ...]:
        """Local names to free when testing the term against the paper's model: the
        default-free ones, plus any held one without which the term cannot reach off."""
        return tuple(p.name for p in self.params() if p.free)

    def implausible(self, p: Mapping[str, float], spec: DamperSpec) -> str:
        """Why these fitted values are not physics ("" when they are): a term that fits
        data only with impossible values stands in for something else."""
        return ""

    def implausible_on(self, p: Mapping[str, float], spec: DamperSpec, ev: Evaluation) -> str:
        """Why the force these values make on a recording (`ev`, the fitted model there)
        is not physics ("" when it is): where a parameter is a level the motion never
        lets the term reach, the rule is on what it reaches."""
        return ""

    def reached(
        self, p: Mapping[str, float], spec: DamperSpec, ev: Evaluation
    ) -> dict[str, tuple[float, str]]:
        """What the term reaches on a recording (`ev`, the fitted model there), by name:
        (value in SI, unit). Where a parameter is a level the motion need not let the term
        reach, this is what a reader compares with a measurement (none by default)."""
        return {}

    def unseen(self, p: Mapping[str, float], x: FloatArray) -> dict[str, float]:
        """Parameters no sample at the positions `x` depends on, with the off values a
        fit reports for them (a force past an onset the stroke never reaches is not
        measured, and must not ride along to a car that travels further)."""
        return {}

    def faint(
        self, p: Mapping[str, float], x: FloatArray, v: FloatArray, limit_n: float
    ) -> dict[str, float]:
        """Off values for a part of the term whose own force stays below `limit_n` (N) at
        every sample (positions `x`, velocities `v`), and for what then moves nothing: a
        part too weak to matter is not measured either (none by default)."""
        return {}

    def unplaced(self, p: Mapping[str, float], x: FloatArray) -> str:
        """Why these fitted values cannot be told apart from other physics on data that
        cover the positions `x` ("" when they can): a term acting only where another
        acts too names nothing."""
        return ""

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        """Starting values worth trying before a fit (local names), where the term's
        effect can vanish at its nominal value (a threshold no sample reaches). `seen`:
        the model without the term on the data, for grids placed where the data are."""
        return [{}]

    def refinements(self) -> dict[str, tuple[float, ...]]:
        """Held parameters (local name: its starts) the diagnosis tries freeing after the
        term's own fit (its starts beside the fit and beside each of `start_grid`'s),
        keeping them only where they explain significantly more: a second parameter freed
        beside the first in a short refit can cost the first its place. None by default."""
        return {}

    def placed(self, x: FloatArray) -> dict[str, float]:
        """Values the data fix before any fit, by local name (a spline's knots span the
        stroke the recording covers); none by default."""
        return {}

    def vehicle_values(self) -> dict[str, float]:
        """Parameter values for the damper on a car, where they differ from the dyno's."""
        return {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


@dataclass(frozen=True)
class Evaluation:
    """One evaluation of the model, per sample: `force` the total (N, positive resisting
    compression), `components` the force parts by name (summing to `force`), `dp` the pressure
    drop across the piston and `p_c` the compression-chamber pressure (Pa, absolute), `outputs`
    what terms report besides force, `state` what each stateful term carries into the next call,
    `x` the rod's position the damper saw (m)."""

    force: FloatArray
    components: dict[str, FloatArray]
    dp: FloatArray
    p_c: FloatArray
    outputs: dict[str, FloatArray]
    state: dict[str, FloatArray]
    x: FloatArray = field(default_factory=lambda: np.zeros(0))  # the rod's position


def _samples(value: ArrayLike, n: int) -> FloatArray:
    """A read-only per-sample view (or copy) of a scalar or an array of n samples."""
    if (
        type(value) is np.ndarray
        and value.dtype == np.float64
        and value.shape == (n,)
        and value.flags.c_contiguous
    ):  # what broadcast_to gives for it, without its cost at every evaluation
        view = value.view()
        view.flags.writeable = False
        return view
    return np.ascontiguousarray(np.broadcast_to(np.asarray(value, dtype=float), (n,)))


def solve_flow(w: Work) -> FloatArray:
    """Δp across the piston (Pa, per sample; positive in compression) that passes the flow demand
    `w.q_demand` through bleed, shim valves and leak (eq. 2-4, 7)."""
    spec = w.spec
    q = w.q_demand
    lam = w.bleed_laminar if w.bleed_laminar.size == q.size else np.zeros_like(q)
    vlam = w.valve_laminar if w.valve_laminar.size == q.size else None
    return solve_signed_drop(
        q,
        w.bleed_compression_m2,
        w.bleed_rebound_m2,
        spec.compression_valve,
        spec.rebound_valve,
        spec.discharge_coefficient,
        spec.oil_density_kg_m3,
        w.k_leak,
        lam,
        w.starts,
        vlam,
    )


@dataclass(frozen=True, eq=False)
class DamperModel:
    """The paper's damper (`spec`) with extra `terms` at parameter `values`.

    `values` maps qualified names (`friction.breakaway_n`) to values; a parameter not in
    it sits at its nominal value (the term "on"). Immutable: `with_values` gives a copy.
    """

    spec: DamperSpec
    terms: tuple[Term, ...] = ()
    values: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        ordered = tuple(sorted(self.terms, key=lambda t: (t.stage, t.name)))
        names = [t.name for t in ordered]
        dupes = {n for n in names if names.count(n) > 1 or n in BASE_COMPONENTS}
        if dupes:
            raise ConfigError(f"term {sorted(dupes)[0]!r} given twice")
        object.__setattr__(self, "terms", ordered)
        known = {t.qualified(p.name) for t in ordered for p in t.params()}
        unknown = sorted(set(self.values) - known)
        if unknown:
            raise ConfigError(f"unknown term parameter {unknown[0]!r}")
        object.__setattr__(self, "values", dict(self.values))

    # -- parameters ---------------------------------------------------------------------
    # A fit builds a model at every evaluation and the evaluation asks for each term's
    # values at each of its stages: the lookups are worked out once per model (the
    # declared parameters once per set of terms, shared by the models derived from it).
    @cached_property
    def _declared(self) -> dict[str, Param]:
        """Each parameter by qualified name (the first term's, were one declared twice)."""
        declared: dict[str, Param] = {}
        for name, p in self.param_list():
            declared.setdefault(name, p)
        return declared

    @cached_property
    def _schedule(self) -> tuple[tuple[Term, int], ...]:
        """(term, stage) in the order the evaluation runs them: by term, then stage."""
        return tuple((t, stage) for t in self.terms for stage in t.run_stages())

    @cached_property
    def _locals(self) -> dict[int, tuple[Term, dict[str, float]]]:
        """Each of the model's terms' values by local name, by the term's id (with the term,
        so that an id another object has taken since is not read as that term's)."""
        return {id(t): (t, self._local_values(t)) for t in self.terms}

    def __getstate__(self) -> dict[str, object]:
        # A model sent to a diagnosis worker and back would carry `_locals` keyed by the ids
        # its terms had in the other process; a forked worker's heap is laid out as its
        # parent's, so such an id can be the id of another of the model's terms here: a
        # sensor lag evaluated once with the friction's values (KeyError 'lvdt_lag_s').
        state = dict(self.__dict__)
        state.pop("_locals", None)
        return state

    def param_list(self) -> list[tuple[str, Param]]:
        """Every term's parameters as (qualified name, Param), in the model's term order."""
        return [(t.qualified(p.name), p) for t in self.terms for p in t.params()]

    def value(self, qualified: str) -> float:
        """The value of a parameter by qualified name (its nominal when not set); ConfigError if
        no term declares it."""
        p = self._declared.get(qualified)
        if p is None:
            raise ConfigError(f"unknown term parameter {qualified!r}")
        return float(self.values.get(qualified, p.nominal))

    def local_values(self, term: Term) -> dict[str, float]:
        """`term`'s parameter values by local name (a copy), nominals where not set."""
        got = self._locals.get(id(term))
        if got is not None and got[0] is term:
            return dict(got[1])  # a copy: theirs
        return self._local_values(term)

    def _local_values(self, term: Term) -> dict[str, float]:
        return {
            p.name: float(self.values.get(term.qualified(p.name), p.nominal)) for p in term.params()
        }

    def with_values(self, values: Mapping[str, float]) -> DamperModel:
        """A copy with `values` (qualified names) set over this model's; ConfigError on a name no
        term declares."""
        unknown = sorted(set(values) - self._declared.keys())
        if unknown:
            raise ConfigError(f"unknown term parameter {unknown[0]!r}")
        return self._derived(self.spec, {**self.values, **values})

    def with_spec(self, spec: DamperSpec) -> DamperModel:
        """A copy on another damper spec, the same terms and values."""
        return self._derived(spec, dict(self.values))

    def _derived(self, spec: DamperSpec, values: dict[str, float]) -> DamperModel:
        """This model's terms (ordered and checked already: __post_init__ is not run
        again) with `spec` and `values` (their names checked by the caller)."""
        new = object.__new__(DamperModel)
        object.__setattr__(new, "spec", spec)
        object.__setattr__(new, "terms", self.terms)
        object.__setattr__(new, "values", values)
        new.__dict__["_declared"] = self._declared  # the same terms
        new.__dict__["_schedule"] = self._schedule
        return new

    def with_terms(self, terms: Iterable[Term]) -> DamperModel:
        """A model of the same spec with these terms instead, keeping the values of the
        parameters they declare."""
        terms = tuple(terms)
        keep = {t.qualified(p.name) for t in terms for p in t.params()}
        return DamperModel(self.spec, terms, {k: v for k, v in self.values.items() if k in keep})

    def off(self) -> DamperModel:
        """Every term at its off value: the paper's model, with the terms still attached."""
        return self.with_values({name: p.off for name, p in self.param_list()})

    def without(self, predicate: type[Term] | str) -> DamperModel:
        """A copy without the terms of a class, or of a name."""
        return self.with_terms(
            t
            for t in self.terms
            if not (t.name == predicate if isinstance(predicate, str) else isinstance(t, predicate))
        )

    def vehicle(self) -> DamperModel:
        """The damper as a car carries it: sensor terms dropped, and each term's
        `vehicle_values` (the oil held at the reference temperature)."""
        kept = self.with_terms(t for t in self.terms if t.vehicle_ok())
        fixed: dict[str, float] = {}
        for t in kept.terms:
            fixed.update({t.qualified(k): v for k, v in t.vehicle_values().items()})
        return kept.with_values(fixed)

    def _local_free(self, t: Term, free: Iterable[str]) -> set[str]:
        qualified = set(free)
        return {p.name for p in t.params() if t.qualified(p.name) in qualified}

    def needs_full_rate(self, free: Iterable[str] = ()) -> bool:
        """Whether any term must run at the recording's own sample rate (`Term.full_rate`), with
        the qualified parameters `free` varied by a fit."""
        free = tuple(free)
        return any(t.full_rate(self.local_values(t), self._local_free(t, free)) for t in self.terms)

    def carries_state(self, free: Iterable[str] = ()) -> bool:
        """Whether a sample's force depends on the motion before it under any term
        (`Term.carries_state`), with the qualified parameters `free` varied by a fit."""
        free = tuple(free)
        return any(
            t.carries_state(self.local_values(t), self._local_free(t, free)) for t in self.terms
        )

    def term(self, name: str) -> Term | None:
        """The model's term of that name, or None."""
        return next((t for t in self.terms if t.name == name), None)

    def penalty(self) -> FloatArray:
        """Every term's regularising residuals (N), concatenated (`Term.penalty`)."""
        parts = [t.penalty(self.local_values(t)) for t in self.terms]
        return np.concatenate(parts) if parts else np.zeros(0)

    # -- evaluation -----------------------------------------------------------------------
    def motion(self, inputs: ModelInputs) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(x, v, a) the damper sees after the MOTION stage (a sensor delay shifts them)."""
        movers = [t for t in self.terms if MOTION in t.run_stages()]
        if not movers:
            return inputs.x, inputs.v, inputs.a
        w = Work(
            spec=self.spec,
            inputs=inputs,
            x=inputs.x,
            v=inputs.v,
            a=inputs.a,
            bleed_compression_m2=np.zeros(0),
            bleed_rebound_m2=np.zeros(0),
            k_leak=np.zeros(0),
            q_demand=np.zeros(0),
            p_c=np.zeros(0),
        )
        for t in movers:
            t.apply(w, self.local_values(t), None, MOTION)
        return w.x, w.v, w.a

    def evaluate(
        self,
        inputs: ModelInputs,
        a_bc: ArrayLike,
        a_bt: ArrayLike,
        state: Mapping[str, FloatArray] | None = None,
    ) -> Evaluation:
        """Force and its components for every sample; a_bc, a_bt per sample or scalar."""
        spec = self.spec
        n = inputs.size
        if state and inputs.starts.size != 1:
            raise ConfigError("carried state needs a single-segment input")
        w = Work(
            spec=spec,
            inputs=inputs,
            x=inputs.x,
            v=inputs.v,
            a=inputs.a,
            bleed_compression_m2=_samples(a_bc, n),
            bleed_rebound_m2=_samples(a_bt, n),
            k_leak=np.full(n, spec.leak_conductance_m3_s_pa),
            q_demand=np.zeros(n),
            p_c=np.zeros(n),
            bleed_laminar=np.full(n, spec.bleed_laminar_pa_s_m),
            valve_laminar=(
                np.full(n, spec.valve_laminar_pa_s) if spec.valve_land_m > 0 else np.zeros(0)
            ),
            gas_volume=gas_volume(spec, inputs.x),
        )
        carry_out: dict[str, FloatArray] = {}

        def run(lo: int, hi: int) -> None:
            for term, stage in self._schedule:
                if lo <= stage < hi:
                    carry = (state or {}).get(term.name)
                    got = term.apply(w, self.local_values(term), carry, stage)
                    if got is not None:
                        carry_out[term.name] = got

        run(0, CHAMBER)
        w.p_c = chamber_pressure(spec, w.x, w.a, inputs)
        w.q_demand = (spec.annulus_area_m2 - spec.couette_area_m2) * w.v
        p_c_base = w.p_c
        run(CHAMBER, FLOW)
        w.dp = solve_flow(w)
        dp_static = w.dp
        run(FLOW, FORCE)
        base = {
            "inertia": spec.piston_rod_mass_kg * w.a,
            "gas": (p_c_base - ATMOSPHERE_PA) * spec.rod_area_m2,
            "hydraulic": dp_static * spec.annulus_area_m2,
            "coulomb": self._coulomb(w, state, carry_out),
        }
        w.parts = {**base, **w.parts}
        run(FORCE, SENSOR)
        w.total = _sum(w.parts.values(), n)
        run(SENSOR, 1000)
        total = (
            _sum(w.parts.values(), n)
            if any(max(t.run_stages()) >= SENSOR for t in self.terms)
            else w.total
        )
        assert w.dp is not None
        return Evaluation(total, w.parts, w.dp, w.p_c, w.outputs, carry_out, w.x)

    def force(self, inputs: ModelInputs, a_bc: ArrayLike, a_bt: ArrayLike) -> FloatArray:
        """The total force per sample (N, positive resisting compression) for bleed areas `a_bc`
        (compression) and `a_bt` (rebound), m² per sample or scalar."""
        return self.evaluate(inputs, a_bc, a_bt).force

    def _coulomb(
        self,
        w: Work,
        state: Mapping[str, FloatArray] | None,
        carry_out: dict[str, FloatArray],
    ) -> FloatArray:
        """The paper's Coulomb friction: its smoothed sign, or with a presliding distance
        the seal's deflection state (model/seal.py), carried as "coulomb"."""
        spec = self.spec
        if spec.friction_presliding_m <= 0.0 or spec.friction_n <= 0.0:
            return np.asarray(spec.friction_n * _smoothed_sign(w.v, spec.friction_velocity_m_s))
        force, end = seal_force(
            w.v,
            w.starts,
            w.dt_s,
            spec.friction_n,
            spec.friction_presliding_m,
            spec.friction_velocity_m_s,
            w.inputs.periodic,
            carry=(state or {}).get("coulomb"),
        )
        carry_out["coulomb"] = end
        return force


# The smoothed signs last worked out: (speeds, smoothing speed, tanh(speeds / smoothing)).
# A fit evaluates the model dozens of times on the same motion, and tanh over every sample
# was a twentieth of a diagnosis (issue 44). Given back only for the same bits, so the
# value is the one tanh would give.
_SIGNS: list[tuple[FloatArray, float, FloatArray]] = []


def _smoothed_sign(v: FloatArray, v_f: float) -> FloatArray:
    """tanh(v / v_f), read-only (one of the last few when v and v_f are the same bits)."""
    flat = type(v) is np.ndarray and v.dtype == np.float64 and v.flags.c_contiguous
    if flat:
        bits = v.view(np.int64)
        for seen, f, sign in _SIGNS:
            same_f = f == v_f and math.copysign(1.0, f) == math.copysign(1.0, v_f)
            if same_f and seen.shape == v.shape and np.array_equal(seen.view(np.int64), bits):
                return sign
    sign = np.tanh(v / v_f)
    if flat:
        sign.flags.writeable = False
        _SIGNS.insert(0, (v.copy(), v_f, sign))
        del _SIGNS[4:]
    return sign


def gas_volume(spec: DamperSpec, x: FloatArray) -> FloatArray:
    """The gas column's volume as the rod enters (eq. 5's V0 - A_rod x)."""
    v0 = spec.gas_volume_m3
    return np.asarray(np.maximum(v0 - spec.rod_area_m2 * x, 1e-3 * v0), dtype=float)


def chamber_pressure(
    spec: DamperSpec, x: FloatArray, a: FloatArray, inputs: ModelInputs
) -> FloatArray:
    """Eq. 5-6; with a measured gas charge per test, the gas part scales with it about
    the charge's mean (so the fitted global gas pressure still sets the level)."""
    p_c = compression_pressure(spec, x, a)
    gp = inputs.gas_pressure_pa
    if gp is None or not np.any(np.isfinite(gp)):
        return p_c
    finite = np.isfinite(gp)
    ratio = np.where(finite, gp / float(np.mean(gp[finite])), 1.0)
    if np.all(ratio == 1.0):  # one charge for every test: p_c + gas * 0, bit for bit
        return p_c
    gas = compression_pressure(spec, x, np.zeros_like(x))
    return np.asarray(p_c + gas * (ratio[inputs.segment_of_sample()] - 1.0), dtype=float)


def _sum(parts: Iterable[FloatArray], n: int) -> FloatArray:
    total = np.zeros(n)
    for p in parts:
        np.add(total, p, out=total)  # total + p, in order, without an array per part
    return total
