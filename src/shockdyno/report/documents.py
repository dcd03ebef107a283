"""DIAG.json and RIDE.json as typed documents.

DIAG.json is defined here whole, for its writer and every reader: `diagnose/verdict.py`
builds a `DiagnosisDoc` (`document`; docs/diagnose.md documents the keys) and
`diagnosis_text` writes it, and the report, the history, `batch` and the commands read it
with `read_diagnosis`. It lives in report/, not beside its writer in diagnose/, because
report may not import diagnose (tests/test_layering.py) and diagnose, history and batch
may all import report. RIDE.json is defined here whole for the same reason: its writer
`ride/study.py` (`RideResult.doc`, docs/ride.md) may import report, report not ride.

A result file gains keys over versions and must still be read when old, so keys not named
here are skipped (`schema.convert(..., unknown_keys=True)`), and a key a writer added
later, or that a hand-written sample may leave out, has the default that shows nothing. A
key every writer has written is required: without it the file is not that result. A
garbled value is one ConfigError line naming the file and the key.

Project imports: the utilities, and fit's EstimateDoc (a finding's term parameter is
FIT.json's term parameter, one definition); report may not import diagnose or ride.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, TypeVar

from shockdyno.fit.result_doc import EstimateDoc
from shockdyno.result_files import RecordingRef, read_result
from shockdyno.schema import OMITTED_AT_DEFAULT, Positive, convert, to_json

T = TypeVar("T")


# -- DIAG.json -------------------------------------------------------------------------
#
# Every key the writer puts in the file, in the order it writes them (kw_only: a field with
# a default may come before one without). A key the first `diagnose` wrote is required; a
# later one has the default an older file implies. `_OMIT`: written only when it holds
# something other than its default, as the writer always has.

_OMIT = OMITTED_AT_DEFAULT


@dataclass(frozen=True, kw_only=True)
class Region:
    """A cell of the located structure: `mismatch.where[]`, `verdict.unexplained[]`."""

    stroke: str  # compression | rebound | both
    x_range_m: tuple[float, float]
    v_range_m_s: tuple[float, float]
    frequencies_hz: tuple[float, ...]
    share: float  # of the structured energy
    rms_n: float | None = None
    near_reversal: bool = False


@dataclass(frozen=True, kw_only=True)
class Follows:
    """A signal what is left follows (`verdict.unexplained[].follows[]`)."""

    signal: str
    label: str
    label_imperial: str | None = None
    family: str = ""  # the feature's family ("position × friction", ...)
    share: float  # of the structure left, explained by this signal alone
    rises_with_it: bool = True
    resembles: tuple[str, ...] = ()  # library terms whose physics the signal is


@dataclass(frozen=True, kw_only=True)
class Coefficient:
    """One feature of a discovered term, its coefficient in SI `unit` (N per feature)."""

    feature: str
    label: str
    label_imperial: str | None = None
    family: str = ""
    symbol: str
    symbol_imperial: str | None = None
    value: float | None
    sd: float | None
    unit: str
    text: str = ""  # value ± sd and unit in display units (SI, with time in minutes)
    text_imperial: str = ""


@dataclass(frozen=True, kw_only=True)
class UnnamedTerm:
    """The discovered term tried for what is left (`verdict.unexplained[].term`)."""

    name: str = "unnamed"
    claimed: bool
    form: str  # SI
    form_imperial: str | None = None
    features: tuple[str, ...] = ()
    coefficients: tuple[Coefficient, ...]
    heldout_gain: float | None
    heldout_detail: str = ""
    in_sample_share: float | None = None
    effect_peak_n: float | None = None
    hint: str = ""
    why_not: str = ""


@dataclass(frozen=True, kw_only=True)
class ResidualPlot:
    """Phase means of what is left against the signal it follows most, and the term's."""

    signal: str
    label: str
    label_imperial: str | None = None
    unit: str
    x: tuple[float, ...]
    residual: tuple[float, ...]
    term: tuple[float, ...] = ()


@dataclass(frozen=True, kw_only=True)
class Unexplained(Region):
    """`verdict.unexplained[]`: what the search left, its largest region's keys (an older
    file has these only) and, newer, its description and a discovered term."""

    regions: tuple[Region, ...] = ()
    axes: dict[str, dict[str, float]] = field(default_factory=dict)
    phase_deg: tuple[float, ...] = ()  # the shortest part of the cycle holding half of it
    phase: str = ""
    follows: tuple[Follows, ...] = ()
    term: UnnamedTerm | None = None
    plot: ResidualPlot | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class Mismatch:
    tested: bool = True  # newer: false when no test has two whole cycles
    significant: bool
    p_value: float | None  # null when not tested
    noise_floor_n: float | None
    structured_rms_n: float | None = None
    structured_share: float | None
    effective_values: float | None = None  # independent values the binned residual holds
    lone_cells: int = 0  # (cycle, bin) cells left out as a lone sample's
    where: tuple[Region, ...]
    # the structure's shares by axis: stroke, speed, frequency_hz, click, test_order, ...
    axes: dict[str, dict[str, float]] = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True)
class Finding:
    """One candidate term of one round of the search, as tried and scored."""

    physics: str
    round: int = 0  # 0: not said
    claimed: bool
    p_value: float
    heldout_gain: float | None  # null when not scored held out
    heldout_detail: str = ""
    lr_n2: float | None = None  # the likelihood ratio's statistic, N²
    effect_rms_n: float | None = None  # the term's own force, RMS and peak
    effect_peak_n: float | None = None
    parameters: dict[str, EstimateDoc]  # FIT.json's shape of a term parameter
    ambiguous_with: tuple[str, ...]
    why_not: str = ""  # why a term that fitted better is not claimed


@dataclass(frozen=True, kw_only=True)
class Indistinguishable:
    """Claimed terms the data cannot tell apart (`verdict.indistinguishable[]`)."""

    group: tuple[str, ...]
    separate_by: str  # the test that would


@dataclass(frozen=True, kw_only=True)
class Calibration:
    """A spec value the recording calibrated (`verdict.calibration[]`)."""

    parameter: str
    spec_value: float
    fitted: float
    sd: float | None
    unit: str
    moved: bool
    beyond_tolerance: bool = False  # further than a damper departs from its drawing
    at_range_end: bool = False  # at an end of the range the calibration may move it in
    # what a fit of the search asked for beyond that, before the value was held within it
    # (diagnose/tolerance.py); with `fitted` inside its range, a claimed term took the rest
    asked: float | None = field(default=None, metadata=_OMIT)
    # the value the recording gives for it (a gas charge written down), which `moved`,
    # `beyond_tolerance` and the text are about instead of `spec_value`
    written: float | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class Verdict:
    physics: tuple[str, ...]  # claimed, most important first
    unexplained: tuple[Unexplained, ...]
    indistinguishable: tuple[Indistinguishable, ...] = ()
    calibration: tuple[Calibration, ...] = ()
    sensor: tuple[str, ...] = ()
    text: str  # in SI
    text_imperial: str | None = None  # newer: the same words in lbf, in, in/s
    remaining_rms_n: float | None = None  # the final model's structured residual
    remaining_p_value: float | None = None


@dataclass(frozen=True, kw_only=True)
class ShortTest:
    """A test of fewer than two whole cycles, left out (`short_tests[]`)."""

    index: int
    clicks: int
    frequency_hz: float
    cycles: float
    reason: str


@dataclass(frozen=True, kw_only=True)
class ScoredTest:
    """A row of `tests[]`: the test's E_t with the baseline and with the final model."""

    index: int
    clicks: int
    frequency_hz: float
    E_t_before: float | None
    E_t_after: float | None


@dataclass(frozen=True, kw_only=True)
class SpecUsed:
    """`info.spec`: the damper spec the diagnosis's model started from."""

    path: str  # as the user gave it; the built-in default as its repository path
    name: str
    default: bool = False
    from_fit: str | None = field(default=None, metadata=_OMIT)  # the --fit whose base spec


@dataclass(frozen=True, kw_only=True)
class DiagnosisInfo:
    wall_s: float | None = None  # how long the diagnosis took
    n_tests: int = 0
    single_frequency: bool = False
    skipped: tuple[str, ...] = ()  # notes on what the search left out
    final_terms: tuple[str, ...] = ()  # the final model's terms
    recording: RecordingRef | None = field(default=None, metadata=_OMIT)
    spec: SpecUsed | None = field(default=None, metadata=_OMIT)
    recording_loss: str | None = field(default=None, metadata=_OMIT)  # a cut-off recording
    fit_provenance: str | None = field(default=None, metadata=_OMIT)  # where --fit came from
    # With `diagnose --report`: the PNGs by key, relative to the JSON's folder, and the
    # units they were drawn in (none said: SI, as `batch diagnose` draws them).
    figures: dict[str, str] = field(default_factory=dict, metadata=_OMIT)
    figures_units: Literal["si", "imperial"] | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class DiagnosisDoc:
    mismatch: Mismatch
    findings: tuple[Finding, ...]
    verdict: Verdict
    short_tests: tuple[ShortTest, ...] = ()
    tests: tuple[ScoredTest, ...]
    info: DiagnosisInfo = field(default_factory=DiagnosisInfo)


# -- RIDE.json -------------------------------------------------------------------------
#
# Written by `ride/study.py` (`RideResult.doc`) and `commands/ride.py` (which names the
# fit's recording), read by the report's ride section. Every key in the order the writer
# writes it; the keys the first ride study wrote and the report shows (`rms`, `flags`,
# `quarter_car`, `damper`) are required, the rest default to what a hand-written sample
# leaves out. A key written only for one kind of damper (linear or fitted) is `_OMIT` at
# None: a fitted damper's empty list of terms is still written as [].


@dataclass(frozen=True, kw_only=True)
class RunRms:
    """A run of `rms[]`: one click setting (null: the linear damper), road and speed."""

    clicks: int | None
    road: str
    speed_kmh: Positive
    rms_ms2: float
    rms_wk_ms2: float
    paper_rms_ms2: float | None  # the paper's Table 7 value, where it has the run
    road_rms_m: float | None = None
    max_abs_stroke_m: float | None = None
    max_abs_stroke_velocity_m_s: float | None = None
    tyre_leaves_road: bool
    stroke_exceeds_travel: bool


@dataclass(frozen=True, kw_only=True)
class ClickSetting:
    """`damper.settings[]`: a click setting of the fitted damper and its bleed areas."""

    clicks: int
    A_bc_m2: float | None = None
    A_bt_m2: float | None = None
    source: str  # "fit", "fit (flagged not identifiable)" or "trend"
    secant_rate_0p1_ns_m: float | None = None  # the damper's secant at ±0.1 m/s


@dataclass(frozen=True, kw_only=True)
class DamperTable:
    """`damper.table`: the force table the runs were integrated on (model/quarter_car.py)."""

    stroke_range_m: tuple[float, float]
    velocity_range_m_s: tuple[float, float]
    max_error_n: float
    runs_outside_table: int | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class Damper:
    """`damper`: the linear damper (`kind`, `c_ns_m`) or the fitted model's."""

    kind: str = ""
    c_ns_m: float | None = field(default=None, metadata=_OMIT)  # linear
    spec: str | None = field(default=None, metadata=_OMIT)  # the spec's name
    spec_path: str | None = field(default=None, metadata=_OMIT)
    globals: dict[str, float] | None = field(default=None, metadata=_OMIT)
    terms: tuple[str, ...] | None = field(default=None, metadata=_OMIT)  # in the car
    terms_dropped: tuple[str, ...] | None = field(default=None, metadata=_OMIT)  # sensor's
    settings: tuple[ClickSetting, ...] = field(default=(), metadata=_OMIT)  # none: linear
    force_at_rest_n: float | None = field(default=None, metadata=_OMIT)
    moving_mass_kg: float | None = field(default=None, metadata=_OMIT)
    table: DamperTable | None = field(default=None, metadata=_OMIT)


@dataclass(frozen=True, kw_only=True)
class RoadLength:
    """`roads[]`: the synthesised road of one speed."""

    speed_kmh: float
    length_m: float
    n_harmonics: int
    harmonic_spacing_rad_per_m: float
    frequency_band_hz: tuple[float, float]


@dataclass(frozen=True, kw_only=True)
class StepRun:
    clicks: int | None
    road: str
    speed_kmh: float
    rms_dt_ms2: float
    rms_half_dt_ms2: float
    relative_change: float


@dataclass(frozen=True, kw_only=True)
class StepCheck:
    """`step_check`: the extreme runs again at dt and dt / 2 (null: --no-step-check)."""

    dt_s: float
    half_dt_s: float
    duration_s: float
    warmup_s: float
    max_relative_change: float
    runs: tuple[StepRun, ...]


@dataclass(frozen=True, kw_only=True)
class Psd:
    method: str
    segment_s: float
    max_hz: float


@dataclass(frozen=True, kw_only=True)
class FlaggedRun:
    clicks: int | None
    road: str
    speed_kmh: float


@dataclass(frozen=True, kw_only=True)
class Flags:
    travel_m: float  # the --travel-mm the runs were flagged against
    tyre_leaves_road: tuple[FlaggedRun, ...] = ()
    stroke_exceeds_travel: tuple[FlaggedRun, ...] = ()
    interpolated_clicks: tuple[int, ...] = ()


@dataclass(frozen=True, kw_only=True)
class Car:
    """`quarter_car`: the paper's Table 5 terms."""

    sprung_mass_kg: float
    unsprung_mass_kg: float
    spring_n_m: float
    tyre_n_m: float


@dataclass(frozen=True, kw_only=True)
class RideDoc:
    schema: str = ""
    fit: str | None = None  # the --fit path as given (null: a linear damper)
    damper: Damper
    quarter_car: Car
    road_band_rad_per_m: tuple[float, float] | None = None
    waviness: float | None = None
    seed: int | None = None
    road_classes: dict[str, float] = field(default_factory=dict)  # A_g by class, m³
    roads: tuple[RoadLength, ...] = ()
    dt_s: float | None = None
    duration_s: float | None = None
    warmup_s: float | None = None
    integrator: str = ""
    stable_step_s: float | None = None
    step_check: StepCheck | None = None
    psd: Psd | None = None
    rms: tuple[RunRms, ...]
    flags: Flags
    wall_time_s: float | None = None
    fit_recording: RecordingRef | None = None  # null for a linear damper or an older fit


# -- reading ---------------------------------------------------------------------------


def read_diagnosis(path: str | Path, flag: str) -> DiagnosisDoc:
    """The DIAG.json at `path`, given as `flag`; else one ConfigError line."""
    doc = read_result(path, flag, "diagnosis")  # refuses a recording, a FIT.json, ...
    return convert(doc, DiagnosisDoc, f"{flag}: {path}", unknown_keys=True)


def diagnosis_text(doc: DiagnosisDoc) -> str:
    """DIAG.json's text: the document `diagnose/verdict.py` built, as JSON."""
    return json.dumps(to_json(doc), indent=2, allow_nan=False) + "\n"


def read_ride(path: str | Path, flag: str) -> RideDoc:
    """The RIDE.json at `path`, given as `flag`; else one ConfigError line."""
    doc = read_result(path, flag, "ride")
    return convert(doc, RideDoc, f"{flag}: {path}", unknown_keys=True)


def ride_text(doc: RideDoc) -> str:
    """RIDE.json's text: the document `ride/study.py` built, as JSON."""
    return json.dumps(to_json(doc), indent=2, allow_nan=False) + "\n"


def typed(value: T | Mapping[str, object], cls: type[T], source: str) -> T:
    """`value` as a `cls`: a writer's dict (`to_json()`, not yet written) is read as its
    file would be. For callers that still pass dicts; `source` names it in an error."""
    if isinstance(value, cls):
        return value
    # Through JSON: numpy scalars become the numbers a file holds (msgspec takes only
    # Python's own), tuples lists.
    return convert(json.loads(json.dumps(value)), cls, source, unknown_keys=True)
