"""The fit result and its JSON form (documented field by field in docs/fit.md).

`globals` holds the calibrated damper parameters as overrides of the base spec: keys are
DamperSpec field names (`friction_n`, `gas_pressure_pa`, ...) or dotted valve fields
(`compression_valve.preload_m`, `rebound_valve.face_area_m2`, ...). `spec_path` names the
base spec. Together they rebuild the fitted damper with `FitResult.spec()`.

A fit JSON is user input, and `spec_path` a path in it: it is followed only to a damper
spec (`spec_file`), never to any file it names.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from shockdyno.atomic import write_text_atomic
from shockdyno.errors import ConfigError, FitError
from shockdyno.fit import forces
from shockdyno.fit.forces import SavedForces
from shockdyno.fit.result_doc import ClickDoc, EstimateDoc, FitDoc, FitInfo, TestDoc, read_fit_doc
from shockdyno.fit.trend import AreaTrend, TrendDoc, nan
from shockdyno.model.composite import DamperModel
from shockdyno.model.params import Estimate
from shockdyno.model.spec import DamperSpec, load_spec
from shockdyno.model.terms import LIBRARY, make_term
from shockdyno.record import adjusters
from shockdyno.result_files import special_file
from shockdyno.schema import check, finite_or_none, to_json

# A damper spec is a few kB of TOML; a "spec" far larger is no spec (and is not read).
MAX_SPEC_BYTES = 1 << 20


@dataclass(frozen=True)
class ClickFit:
    clicks: int
    gas_clicks: int
    a_bc_m2: float
    a_bt_m2: float
    a_b_talbott_m2: float
    a_bc_sd_m2: float = float("nan")
    a_bt_sd_m2: float = float("nan")
    a_b_talbott_sd_m2: float = float("nan")
    identifiable_bc: bool = True
    identifiable_bt: bool = True
    # Added by the fit (optional in the JSON): eq. 8 at the optimum over the click's
    # objective samples (N), and the flow-weighted share of the flow through the bleed.
    objective_n: float = float("nan")
    objective_talbott_n: float = float("nan")
    bleed_share_bc: float = float("nan")
    bleed_share_bt: float = float("nan")
    # Every adjuster's clicks of a damper with several ({} for the one rod adjuster,
    # whose clicks are `clicks`; FIT.json writes the key only when it has some)
    adjusters: dict[str, int] = field(default_factory=dict)

    @property
    def setting(self) -> tuple[tuple[str, int], ...]:
        return tuple(sorted(self.adjusters.items()))


@dataclass(frozen=True)
class TestValidation:
    """One test's validation: E_t, E_x, E_xd (and the mean absolute error, N) of the
    proposed model and of Talbott's, on every measured sample (fit JSON `tests[]`)."""

    __test__ = False  # not a pytest test class, despite the name

    index: int
    clicks: int
    gas_clicks: int
    frequency_hz: float
    motion: str
    n_samples: int
    duration_s: float
    temperature_mean_c: float | None
    proposed: dict[str, float]
    talbott: dict[str, float]
    adjusters: dict[str, int] = field(default_factory=dict)

    def doc(self) -> TestDoc:
        """FIT.json's `tests[]` entry."""
        return TestDoc(
            index=self.index,
            clicks=self.clicks,
            gas_clicks=self.gas_clicks,
            adjusters=dict(self.adjusters),
            frequency_hz=self.frequency_hz,
            motion=self.motion,
            n_samples=self.n_samples,
            duration_s=self.duration_s,
            temperature_mean_C=self.temperature_mean_c,
            proposed={k: finite_or_none(v) for k, v in self.proposed.items()},
            talbott={k: finite_or_none(v) for k, v in self.talbott.items()},
        )

    @staticmethod
    def from_doc(d: TestDoc) -> TestValidation:
        return TestValidation(
            index=d.index,
            clicks=d.clicks,
            gas_clicks=d.gas_clicks,
            frequency_hz=d.frequency_hz,
            motion=d.motion,
            n_samples=d.n_samples,
            duration_s=d.duration_s,
            temperature_mean_c=d.temperature_mean_C,
            proposed={k: nan(v) for k, v in d.proposed.items()},
            talbott={k: nan(v) for k, v in d.talbott.items()},
            adjusters=dict(d.adjusters),
        )


@dataclass
class FitResult:
    spec_path: str
    globals: dict[str, float]
    clicks: list[ClickFit]
    trend: dict[str, AreaTrend] = field(default_factory=dict)
    tests: list[TestValidation] = field(default_factory=list)
    info: FitInfo = field(default_factory=FitInfo)  # how it ran, what from (docs/fit.md)
    # Fitted physics terms: {term: {local parameter: Estimate}} (docs/fit.md).
    terms: dict[str, dict[str, Estimate]] = field(default_factory=dict)
    # The folder of the fit JSON this was read from (None: made here): a relative
    # spec_path not found from the working folder is looked for beside the fit.
    origin: Path | None = field(default=None, compare=False, repr=False)
    # The model's forces a report draws (fit/forces.py): made by the fit, read back from
    # the file beside FIT.json; None: the report computes them from this result.
    saved: SavedForces | None = field(default=None, compare=False, repr=False)

    @staticmethod
    def from_spec(spec_path: str | Path, clicks: Sequence[int]) -> FitResult:
        """What a perfect fit would give: the spec's own bleed areas at these clicks.

        Talbott's single area is taken as the mean of the two (no fit to choose it).
        Useful for a ride study of the nominal damper, and as known truth in checks.
        """
        spec = load_spec(spec_path)
        fits = []
        for n in clicks:
            a_bc, a_bt = (float(a) for a in spec.bleed_areas(n))
            fits.append(ClickFit(int(n), 0, a_bc, a_bt, 0.5 * (a_bc + a_bt)))
        return FitResult(spec_path=str(spec_path), globals={}, clicks=fits)

    def spec(self) -> DamperSpec:
        return self._base()[1].with_values(self.globals)

    def spec_file(self) -> Path:
        """The base spec `spec_path` names, checked to be a damper spec TOML before it is
        read: a .toml regular file of at most MAX_SPEC_BYTES (not a folder, FIFO or
        device). A relative path is the one the fit was given, from the working folder
        (as `fit --spec` wrote it), else beside the fit JSON. Anything else, and a file
        `load_spec` refuses, is one ConfigError line."""
        return self._base()[0]

    def _base(self) -> tuple[Path, DamperSpec]:
        named = Path(self.spec_path)
        said = f"the fit's spec_path {self.spec_path!r}"
        if named.suffix.lower() != ".toml":
            raise ConfigError(f"{said} is not a damper spec (a .toml file); not read")
        tried = [named]
        if not named.is_absolute() and self.origin is not None:
            tried.append(self.origin / named)
        path = next((p for p in tried if p.exists()), None)
        if path is None:
            where = " or ".join(str(p) for p in tried)
            raise ConfigError(f"{said}: damper spec not found: {where}")
        if path.is_dir() or special_file(path):
            raise ConfigError(f"{said}: {path} is not a regular file; not read")
        try:
            size = path.stat().st_size
        except OSError as exc:
            raise ConfigError(f"{said}: cannot read {path} ({exc.strerror or exc})") from None
        if size > MAX_SPEC_BYTES:
            raise ConfigError(
                f"{said}: {path} is {size} bytes, no damper spec (at most {MAX_SPEC_BYTES}); "
                "not read"
            )
        try:
            return path, load_spec(path)
        except ConfigError as exc:
            raise ConfigError(f"{said} is not a damper spec: {exc}") from None

    def model(self) -> DamperModel:
        """The fitted damper: spec with the globals, and the fitted terms at their values.

        A result written before terms existed had its channel delay in
        info.calibration.force_delay_s: it becomes the sensor_lag term's delay.
        """
        terms = self.terms
        if not terms:
            cal = self.info.calibration
            delay = cal.force_delay_s if cal is not None else None
            if delay:
                terms = {"sensor_lag": {"delay_s": Estimate(float(delay), float("nan"), "s")}}
        built = [make_term(name) for name in terms]
        # JSON has no infinity: a value written as null is the parameter's infinite off
        # value (cavitation's floor at -inf: no clamp).
        values = {
            f"{name}.{k}": est.value if math.isfinite(est.value) else _off(name, k)
            for name, params in terms.items()
            for k, est in params.items()
            if f"{name}.{k}" not in RETIRED
        }
        return DamperModel(self.spec(), tuple(built), values)

    def adjuster_names(self) -> list[str]:
        """The adjusters of a fit of a damper with several ([] for the one rod)."""
        return adjusters.names(c.adjusters for c in self.clicks)

    def for_adjuster(self, name: str) -> FitResult:
        """The fit along one adjuster's line (record/adjusters.py): the settings with the
        other adjusters at the base, `clicks` the adjuster's; the trend of the path it
        acts on against its clicks, and the other path's area held at its mean on the line
        (a constant: that adjuster did not move). What the click chart, the model's loops
        and the damper tables read, as of a damper with one adjuster."""
        known = self.adjuster_names()
        if name not in known:
            raise FitError(f"the fit has no adjuster {name!r} (it has {', '.join(known) or 'one'})")
        at = adjusters.base([c.adjusters for c in self.clicks if c.adjusters])
        line = [
            replace(c, clicks=c.adjusters[name])
            for c in self.clicks
            if adjusters.on_line(c.adjusters, name, at)
        ]
        tests = [
            replace(t, clicks=t.adjusters[name])
            for t in self.tests
            if adjusters.on_line(t.adjusters, name, at)
        ]
        gas = self.main_gas_clicks()
        trend: dict[str, AreaTrend] = {}
        for key, attr in (("A_bc", "a_bc_m2"), ("A_bt", "a_bt_m2")):
            t = self.trend.get(key)
            if t is not None and t.adjuster == name:
                trend[key] = t
                continue
            held = [c for c in line if c.gas_clicks == gas]
            if held:
                mean = float(np.mean([getattr(c, attr) for c in held]))
                trend[key] = AreaTrend(
                    degree=0,
                    coefficients=(mean,),
                    clicks_used=tuple(c.clicks for c in held),
                    rms_m2=float(np.std([getattr(c, attr) for c in held])),
                    r2=math.nan,
                    selection=f"held ({adjusters.held(name, at)})",
                    gas_clicks=gas,
                    adjuster=name,
                )
        info = self.info
        reached = info.velocity_range
        if reached is not None:  # each entry of the line, at the adjuster's clicks
            info = replace(
                info,
                velocity_range=tuple(
                    replace(e, clicks=e.adjusters[name])
                    for e in reached
                    if name in e.adjusters and adjusters.on_line(e.adjusters, name, at)
                ),
            )
        return FitResult(
            spec_path=self.spec_path,
            globals=self.globals,
            clicks=line,
            trend=trend,
            tests=tests,
            info=info,
            terms=self.terms,
            saved=self.saved,
        )

    def main_gas_clicks(self) -> int:
        """The gas setting with the most fitted rod clicks (the trend's; the lowest on a
        tie), 0 for a fit without clicks."""
        counts: dict[int, int] = {}
        for c in self.clicks:
            counts[c.gas_clicks] = counts.get(c.gas_clicks, 0) + 1
        return min(counts, key=lambda g: (-counts[g], g)) if counts else 0

    def areas(
        self, clicks: int, model: str = "proposed", gas_clicks: int | None = None
    ) -> tuple[float, float]:
        """(A_bc, A_bt) at a click setting: the fitted value, else the trend. `gas_clicks`
        None: the main gas setting (a sweep over the gas bottle's clicks fits each pair;
        the first pair with these rod clicks, whatever its gas, was taken before)."""
        gas = self.main_gas_clicks() if gas_clicks is None else gas_clicks
        at = f" at {gas} gas clicks" if gas or any(c.gas_clicks for c in self.clicks) else ""
        for c in self.clicks:
            if c.clicks == clicks and c.gas_clicks == gas:
                if model == "talbott":
                    return c.a_b_talbott_m2, c.a_b_talbott_m2
                return c.a_bc_m2, c.a_bt_m2
        fitted = [c.clicks for c in self.clicks if c.gas_clicks == gas]
        if self.clicks and not fitted:
            raise FitError(f"the fit has no result{at}")
        if fitted and not min(fitted) <= clicks <= max(fitted):
            raise FitError(
                f"{clicks} clicks is outside the fitted range {min(fitted)}-{max(fitted)}{at}; "
                "the trend is not extrapolated"
            )
        trend_bc, trend_bt = self.trend.get("A_bc"), self.trend.get("A_bt")
        if (
            model == "proposed"
            and trend_bc is not None
            and trend_bt is not None
            and trend_bc.gas_clicks == gas
        ):
            for name, trend in (("A_bc", trend_bc), ("A_bt", trend_bt)):
                used = trend.clicks_used
                if used and not trend.adjuster and not min(used) <= clicks <= max(used):
                    # A trend read only where its clicks are: one identifiable click
                    # (a closed needle beside it) made a constant that drew every click
                    # between as that one.
                    raise FitError(
                        f"{clicks} clicks: the {name} trend rests on clicks "
                        f"{min(used)}-{max(used)} only (the others not identifiable){at}"
                    )
            return max(trend_bc.at(clicks), 0.0), max(trend_bt.at(clicks), 0.0)
        raise FitError(f"the fit has no result for {clicks} clicks{at}")

    def problem(self) -> str:
        """Why this result cannot be used as a damper ("" when it can): a global or a term
        value that is not a number, a bleed area that is negative or not a number."""
        for key, value in self.globals.items():
            if not math.isfinite(value):
                return f"global {key} is {value}"
        for c in self.clicks:
            for name, area in (("A_bc", c.a_bc_m2), ("A_bt", c.a_bt_m2)):
                if not (math.isfinite(area) and area >= 0):
                    return f"{name} at {c.clicks} clicks is {area:g} m²"
        for term, params in self.terms.items():
            for k, est in params.items():
                if not math.isfinite(est.value) and math.isfinite(_off(term, k)):
                    return f"term parameter {term}.{k} is {est.value}"
        try:  # the damper it describes: its spec_path, globals and terms, within the spec's rules
            spec = self.spec()
            check(spec, f"the spec {self.spec_path} with the fit's globals")
            spec.validate()
            self.model()
        except ConfigError as exc:
            return str(exc)
        return ""

    def require_usable(self, label: str) -> FitResult:
        """Self, or a one-line ConfigError naming the bad value and the file."""
        problem = self.problem()
        if problem:
            raise ConfigError(f"{label}: not a usable fit: {problem}")
        return self

    def doc(self) -> FitDoc:
        """FIT.json, as its typed document (fit/result_doc.py)."""
        return FitDoc(
            spec_path=self.spec_path,
            globals=self.globals,
            clicks=tuple(
                ClickDoc(
                    clicks=c.clicks,
                    gas_clicks=c.gas_clicks,
                    adjusters=dict(c.adjusters),
                    A_bc_m2=c.a_bc_m2,
                    A_bt_m2=c.a_bt_m2,
                    A_b_talbott_m2=c.a_b_talbott_m2,
                    A_bc_sd_m2=finite_or_none(c.a_bc_sd_m2),
                    A_bt_sd_m2=finite_or_none(c.a_bt_sd_m2),
                    A_b_talbott_sd_m2=finite_or_none(c.a_b_talbott_sd_m2),
                    identifiable_bc=c.identifiable_bc,
                    identifiable_bt=c.identifiable_bt,
                    objective_n=finite_or_none(c.objective_n),
                    objective_talbott_n=finite_or_none(c.objective_talbott_n),
                    bleed_share_bc=finite_or_none(c.bleed_share_bc),
                    bleed_share_bt=finite_or_none(c.bleed_share_bt),
                )
                for c in self.clicks
            ),
            terms={
                name: {k: EstimateDoc.of(est) for k, est in params.items()}
                for name, params in self.terms.items()
            },
            trend={name: TrendDoc.of(t) for name, t in self.trend.items()},
            tests=tuple(t.doc() for t in self.tests),
            info=self.info,
        )

    def to_json(self) -> dict[str, Any]:  # Any: a JSON object's values, for json.dumps
        out: dict[str, Any] = to_json(self.doc())
        return out

    def save(self, path: str | Path) -> None:
        """Write the JSON, and beside it the model's forces a report reads when the fit
        made them (`saved`, fit/forces.py); each file is replaced only once complete."""
        text = json.dumps(self.to_json(), indent=2, allow_nan=False) + "\n"
        write_text_atomic(Path(path), text)
        if self.saved is not None:
            forces.write(forces.sidecar_path(path), self.saved, text)

    @staticmethod
    def load(path: str | Path, flag: str = "--fit") -> FitResult:
        d = read_fit_doc(Path(path), flag)
        return FitResult(
            origin=Path(path).parent,
            spec_path=d.spec_path,
            globals=dict(d.globals),
            clicks=[
                ClickFit(
                    clicks=c.clicks,
                    gas_clicks=c.gas_clicks,
                    a_bc_m2=c.A_bc_m2,
                    a_bt_m2=c.A_bt_m2,
                    a_b_talbott_m2=c.A_b_talbott_m2,
                    a_bc_sd_m2=nan(c.A_bc_sd_m2),
                    a_bt_sd_m2=nan(c.A_bt_sd_m2),
                    a_b_talbott_sd_m2=nan(c.A_b_talbott_sd_m2),
                    identifiable_bc=c.identifiable_bc,
                    identifiable_bt=c.identifiable_bt,
                    objective_n=nan(c.objective_n),
                    objective_talbott_n=nan(c.objective_talbott_n),
                    bleed_share_bc=nan(c.bleed_share_bc),
                    bleed_share_bt=nan(c.bleed_share_bt),
                    adjusters=dict(c.adjusters),
                )
                for c in d.clicks
            ],
            trend={k: t.trend() for k, t in d.trend.items()},
            tests=[TestValidation.from_doc(t) for t in d.tests],
            info=d.info,
            terms={
                name: {k: e.estimate() for k, e in params.items()}
                for name, params in d.terms.items()
            },
        )


# Parameters a term no longer has, read from older fits and left out: the chamber state
# takes the piston's conductance from the flow law itself.
RETIRED = frozenset({"compressibility.valve_conductance_m3_s_pa"})


def _off(term: str, local: str) -> float:
    """A term parameter's off value (nan for an unknown one)."""
    cls = LIBRARY.get(term)
    for p in cls.PARAMS if cls is not None else ():
        if p.name == local:
            return p.off
    return math.nan
