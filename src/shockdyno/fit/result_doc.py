"""FIT.json as a typed document: its one definition, which `FitResult.doc()` builds and
writes (`schema.to_json`) and every reader reads (`read_fit_doc`, `FitResult.load`).

Every key the writer puts in the file is declared here, in the order it writes them
(kw_only: a field with a default may come before one without). A key every fit has written
is required; one added later, or one a hand-made result may leave out, has the default an
older file implies. `_OMIT`: written only when it holds something other than its default,
as the writer always has (the adjusters of a damper with several, a term parameter held
fixed, the GA's settings, what `fit` adds to `fit_sweep`'s info). Keys added by later
versions are ignored when read (a result outlives the code that wrote it). JSON has no NaN:
a value that may be non-finite is `float | None`, None read back as NaN.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

from msgspec import Meta

from shockdyno.fit.trend import TrendDoc, nan
from shockdyno.model.params import Estimate
from shockdyno.result_files import RecordingRef, read_result
from shockdyno.schema import OMITTED_AT_DEFAULT, convert, finite_or_none

Clicks = Annotated[int, Meta(ge=0)]
_OMIT = OMITTED_AT_DEFAULT


@dataclass(frozen=True, kw_only=True)
class ClickDoc:
    """`clicks[]`: one click setting's fitted areas (m²) with their 1-σ."""

    clicks: Clicks
    gas_clicks: Clicks = 0
    # every adjuster's clicks of a damper with several (none: the one rod adjuster)
    adjusters: dict[str, Clicks] = field(default_factory=dict, metadata=_OMIT)
    A_bc_m2: float
    A_bt_m2: float
    A_b_talbott_m2: float
    A_bc_sd_m2: float | None = None
    A_bt_sd_m2: float | None = None
    A_b_talbott_sd_m2: float | None = None
    identifiable_bc: bool = True
    identifiable_bt: bool = True
    objective_n: float | None = None
    objective_talbott_n: float | None = None
    bleed_share_bc: float | None = None
    bleed_share_bt: float | None = None


@dataclass(frozen=True, kw_only=True)
class TestDoc:
    """`tests[]`: one test's validation, both models' errors on every measured sample."""

    __test__ = False  # not a pytest class

    index: int
    clicks: int
    gas_clicks: int = 0
    adjusters: dict[str, Clicks] = field(default_factory=dict, metadata=_OMIT)
    frequency_hz: float
    motion: str = "sine"
    n_samples: int = 0
    duration_s: float = 0.0
    temperature_mean_C: float | None = None
    proposed: dict[str, float | None] = field(default_factory=dict)
    talbott: dict[str, float | None] = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True)
class EstimateDoc:
    """`terms.TERM.PARAM`: a fitted term parameter in SI `unit`."""

    value: float | None  # None: not finite (an infinite off value)
    sd: float | None = None
    unit: str = ""
    fixed: bool = field(default=False, metadata=_OMIT)
    at_bound: bool = field(default=False, metadata=_OMIT)

    def estimate(self) -> Estimate:
        return Estimate(nan(self.value), nan(self.sd), self.unit, self.fixed, self.at_bound)

    @staticmethod
    def of(e: Estimate) -> EstimateDoc:
        return EstimateDoc(
            value=finite_or_none(e.value),
            sd=finite_or_none(e.sd),
            unit=e.unit,
            fixed=e.fixed,
            at_bound=e.at_bound,
        )


@dataclass(frozen=True, kw_only=True)
class GaInfo:
    """`info.ga`, with `--optimizer ga` only: the GA's settings (Table 1)."""

    population: int
    generations: int
    elite_count: int
    crossover_fraction: float
    variable_map: str


@dataclass(frozen=True, kw_only=True)
class CalibrationInfo:
    """`info.calibration`: the joint calibration of the globals and terms."""

    least_squares_evaluations: int | None = None
    start: str = ""  # the start kept: nominal, plain fit, ...
    rms_residual_n: float | None = None
    residual_correlation_factor: float | None = None
    # Kept for readers of older results: the sensor_lag term's delay (an older result's
    # only record of it: `FitResult.model()`).
    force_delay_s: float | None = None
    force_delay_sd_s: float | None = None
    globals_nominal: dict[str, float | None] = field(default_factory=dict)
    globals_sd: dict[str, float | None] = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True)
class Table4Doc:
    """`info.table4[]`: one frequency's mean errors (`validate.Table4Row`)."""

    frequency_hz: float
    n_tests: int
    proposed: dict[str, float | None]
    talbott: dict[str, float | None]
    enhancement_pct: dict[str, float | None]


@dataclass(frozen=True, kw_only=True)
class VelocityReach:
    """`info.velocity_range[]`: the fastest velocities a click setting's tests reached."""

    clicks: int
    gas_clicks: int = 0
    adjusters: dict[str, Clicks] = field(default_factory=dict, metadata=_OMIT)
    compression_m_s: float  # > 0
    rebound_m_s: float  # < 0


@dataclass(frozen=True, kw_only=True)
class FitInfo:
    """`info`: how the fit ran and what it was made from (docs/fit.md). `fit_sweep` writes
    its keys together and `fit` adds the recording's; none is written at its default, so
    a result made in code (`FitResult.from_spec`) has an empty `info`."""

    ga: GaInfo | None = field(default=None, metadata=_OMIT)
    optimizer: str | None = field(default=None, metadata=_OMIT)
    seed: int | None = field(default=None, metadata=_OMIT)
    terms: tuple[str, ...] | None = field(default=None, metadata=_OMIT)
    free_term_parameters: tuple[str, ...] | None = field(default=None, metadata=_OMIT)
    wall_s: float | None = field(default=None, metadata=_OMIT)
    model_evaluations: int | None = field(default=None, metadata=_OMIT)
    model_samples_evaluated: int | None = field(default=None, metadata=_OMIT)
    objective_rate_hz: float | None = field(default=None, metadata=_OMIT)
    objective_samples: int | None = field(default=None, metadata=_OMIT)
    # eq. 8 summed over the clicks (null, like every info number, when not finite)
    objective_n: float | None = field(default=None, metadata=_OMIT)
    objective_talbott_n: float | None = field(default=None, metadata=_OMIT)
    calibration: CalibrationInfo | None = field(default=None, metadata=_OMIT)
    n_tests: int | None = field(default=None, metadata=_OMIT)
    skipped: tuple[str, ...] | None = field(default=None, metadata=_OMIT)
    table4: tuple[Table4Doc, ...] | None = field(default=None, metadata=_OMIT)
    # Added by `fit` and `batch fit` (fit/file.py):
    recording: RecordingRef | None = field(default=None, metadata=_OMIT)
    velocity_range: tuple[VelocityReach, ...] | None = field(default=None, metadata=_OMIT)
    recording_loss: str | None = field(default=None, metadata=_OMIT)  # a cut-off recording

    @property
    def recording_sha256(self) -> str | None:
        """The recording's hash (None: an older fit, or one made in code, does not say)."""
        return (self.recording.sha256 or None) if self.recording is not None else None


@dataclass(frozen=True, kw_only=True)
class FitDoc:
    spec_path: str
    globals: dict[str, float]
    clicks: tuple[ClickDoc, ...]
    terms: dict[str, dict[str, EstimateDoc]] = field(default_factory=dict)
    trend: dict[str, TrendDoc] = field(default_factory=dict)
    tests: tuple[TestDoc, ...] = ()
    info: FitInfo = field(default_factory=FitInfo)


def read_fit_doc(path: Path, flag: str) -> FitDoc:
    """FIT.json at `path`, typed; a recording, a DIAG.json or a garbled value is one
    ConfigError line naming `flag`, the file and the key."""
    doc = read_result(path, flag, "fit")
    return convert(doc, FitDoc, f"{flag}: {path}", unknown_keys=True)
