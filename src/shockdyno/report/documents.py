"""What the report reads of a DIAG.json and a RIDE.json, as typed documents.

The writers are `diagnose/verdict.py` (`to_json`, documented in docs/diagnose.md) and
`ride/study.py` (`RideResult.to_json`, docs/ride.md); only the keys the page shows are
described here. A result file gains keys over versions and must still be read when old,
so keys not named here are skipped (`schema.convert(..., unknown_keys=True)`), and a key a
writer added later, or that a hand-written sample may leave out, has the default that
shows nothing. A key every writer has written is required: without it the file is not
that result. A garbled value is one ConfigError line naming the file and the key.

No project imports beyond the utilities: report may not import diagnose or ride.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, TypeVar

from shockdyno.result_files import read_result
from shockdyno.schema import Positive, convert

T = TypeVar("T")


@dataclass(frozen=True)
class RecordingRef:
    """A result's `info.recording` (or a ride's `fit_recording`): what it was made from."""

    file: str
    sha256: str


# -- DIAG.json -------------------------------------------------------------------------


@dataclass(frozen=True)
class Region:
    """A cell of the located structure: `mismatch.where[]`, `verdict.unexplained[]`."""

    stroke: str  # compression | rebound | both
    x_range_m: tuple[float, float]
    v_range_m_s: tuple[float, float]
    frequencies_hz: tuple[float, ...]
    share: float  # of the structured energy
    rms_n: float | None = None
    near_reversal: bool = False


@dataclass(frozen=True)
class Follows:
    """A signal what is left follows (`verdict.unexplained[].follows[]`)."""

    signal: str
    label: str
    share: float  # of the structure left, explained by this signal alone
    label_imperial: str | None = None
    rises_with_it: bool = True
    resembles: tuple[str, ...] = ()  # library terms whose physics the signal is


@dataclass(frozen=True)
class Coefficient:
    """One feature of a discovered term, its coefficient in SI `unit` (N per feature)."""

    feature: str
    label: str
    symbol: str
    value: float | None
    sd: float | None
    unit: str
    label_imperial: str | None = None
    symbol_imperial: str | None = None
    text: str = ""  # value ± sd and unit in display units (SI, with time in minutes)
    text_imperial: str = ""


@dataclass(frozen=True)
class UnnamedTerm:
    """The discovered term tried for what is left (`verdict.unexplained[].term`)."""

    claimed: bool
    form: str  # SI
    coefficients: tuple[Coefficient, ...]
    heldout_gain: float | None
    form_imperial: str | None = None
    heldout_detail: str = ""
    hint: str = ""
    why_not: str = ""


@dataclass(frozen=True)
class ResidualPlot:
    """Phase means of what is left against the signal it follows most, and the term's."""

    signal: str
    label: str
    unit: str
    x: tuple[float, ...]
    residual: tuple[float, ...]
    term: tuple[float, ...] = ()
    label_imperial: str | None = None


@dataclass(frozen=True)
class Unexplained(Region):
    """`verdict.unexplained[]`: what the search left, its largest region's keys (an older
    file has these only) and, newer, its description and a discovered term."""

    regions: tuple[Region, ...] = ()
    phase: str = ""
    follows: tuple[Follows, ...] = ()
    term: UnnamedTerm | None = None
    plot: ResidualPlot | None = None


@dataclass(frozen=True)
class Mismatch:
    significant: bool
    p_value: float | None  # null when not tested
    noise_floor_n: float | None
    structured_share: float | None
    where: tuple[Region, ...]
    tested: bool = True  # newer: false when no test has two whole cycles


@dataclass(frozen=True)
class Parameter:
    """One fitted parameter of a finding's term, in SI `unit`; null where not estimated."""

    value: float | None
    sd: float | None
    unit: str
    fixed: bool = False


@dataclass(frozen=True)
class Finding:
    """One candidate term of one round of the search."""

    physics: str
    claimed: bool
    p_value: float
    heldout_gain: float | None  # null when not scored held out
    parameters: dict[str, Parameter]
    ambiguous_with: tuple[str, ...]
    effect_peak_n: float | None = None


@dataclass(frozen=True)
class Calibration:
    """A spec value the recording calibrated (`verdict.calibration[]`)."""

    parameter: str
    spec_value: float
    fitted: float
    sd: float | None
    unit: str
    moved: bool


@dataclass(frozen=True)
class Verdict:
    text: str  # in SI
    physics: tuple[str, ...]  # claimed, most important first
    unexplained: tuple[Unexplained, ...]
    text_imperial: str | None = None  # newer: the same words in lbf, in, in/s
    calibration: tuple[Calibration, ...] = ()
    sensor: tuple[str, ...] = ()


@dataclass(frozen=True)
class ScoredTest:
    """A row of `tests[]`: the test's E_t with the baseline and with the final model."""

    index: int
    clicks: int
    frequency_hz: float
    E_t_before: float | None
    E_t_after: float | None


@dataclass(frozen=True)
class SpecUsed:
    """`info.spec`: the damper spec the diagnosis's model started from."""

    path: str  # as the user gave it; the built-in default as its repository path
    name: str
    default: bool = False
    from_fit: str | None = None  # the --fit whose base spec it is


@dataclass(frozen=True)
class DiagnosisInfo:
    spec: SpecUsed | None = None
    recording: RecordingRef | None = None
    # With `diagnose --report`: the PNGs by key, relative to the JSON's folder.
    figures: dict[str, str] = field(default_factory=dict)
    figures_units: Literal["si", "imperial"] = "si"


@dataclass(frozen=True)
class DiagnosisDoc:
    mismatch: Mismatch
    findings: tuple[Finding, ...]
    verdict: Verdict
    tests: tuple[ScoredTest, ...]
    info: DiagnosisInfo = field(default_factory=DiagnosisInfo)


# -- RIDE.json -------------------------------------------------------------------------


@dataclass(frozen=True)
class RunRms:
    """A run of `rms[]`: one click setting (null: the linear damper), road and speed."""

    clicks: int | None
    road: str
    speed_kmh: Positive
    rms_ms2: float
    rms_wk_ms2: float
    paper_rms_ms2: float | None  # the paper's Table 7 value, where it has the run
    tyre_leaves_road: bool
    stroke_exceeds_travel: bool


@dataclass(frozen=True)
class ClickSetting:
    clicks: int
    source: str  # "fit", "fit (flagged not identifiable)" or "trend"


@dataclass(frozen=True)
class Damper:
    settings: tuple[ClickSetting, ...] = ()  # none for a linear damper


@dataclass(frozen=True)
class Flags:
    travel_m: float  # the --travel-mm the runs were flagged against


@dataclass(frozen=True)
class Car:
    """`quarter_car`: the paper's Table 5 terms."""

    sprung_mass_kg: float
    unsprung_mass_kg: float
    spring_n_m: float
    tyre_n_m: float


@dataclass(frozen=True)
class RideDoc:
    rms: tuple[RunRms, ...]
    flags: Flags
    quarter_car: Car
    damper: Damper
    fit_recording: RecordingRef | None = None  # null for a linear damper or an older fit


# -- reading ---------------------------------------------------------------------------


def read_diagnosis(path: str | Path, flag: str) -> DiagnosisDoc:
    """The DIAG.json at `path`, given as `flag`; else one ConfigError line."""
    doc = read_result(path, flag, "diagnosis")  # refuses a recording, a FIT.json, ...
    return convert(doc, DiagnosisDoc, f"{flag}: {path}", unknown_keys=True)


def read_ride(path: str | Path, flag: str) -> RideDoc:
    """The RIDE.json at `path`, given as `flag`; else one ConfigError line."""
    doc = read_result(path, flag, "ride")
    return convert(doc, RideDoc, f"{flag}: {path}", unknown_keys=True)


def typed(value: T | Mapping[str, Any], cls: type[T], source: str) -> T:
    """`value` as a `cls`: a writer's dict (`to_json()`, not yet written) is read as its
    file would be. For callers that still pass dicts; `source` names it in an error."""
    if isinstance(value, cls):
        return value
    # Through JSON: numpy scalars become the numbers a file holds (msgspec takes only
    # Python's own), tuples lists.
    return convert(json.loads(json.dumps(value)), cls, source, unknown_keys=True)
