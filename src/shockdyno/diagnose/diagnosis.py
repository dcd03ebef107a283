"""What a diagnosis found: each candidate tried (`Trial`), the spec values calibrated,
the tests' scores, and the whole `Diagnosis` that verdict.py turns into DIAG.json."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.data import Data
from shockdyno.diagnose.discover import Described
from shockdyno.diagnose.fitting import Fitted
from shockdyno.diagnose.locate import Location
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.stats import MismatchStat, at_bound
from shockdyno.model.params import Estimate
from shockdyno.report.documents import Indistinguishable

FloatArray = NDArray[np.float64]
Progress = Callable[[str, float], None]


@dataclass
class Trial:
    """One candidate term tried in one round of the search: its refit's scores, the term's
    parameters as fitted, and whether it is claimed (and why not). The search edits it as
    later rounds decide; verdict.py makes each one a row of DIAG.json's `findings`
    (report/documents.py `Finding`)."""

    physics: str
    round: int
    claimed: bool
    p_value: float
    lr_n2: float
    heldout_gain: float
    heldout_detail: str
    effect_rms_n: float
    effect_peak_n: float
    parameters: dict[str, Estimate]  # the term's, at the fit that was scored
    ambiguous_with: list[str] = field(default_factory=list)
    why_not: str = ""
    note: str = ""  # said of a claimed term beside its claim (claims.borderline)


@dataclass(frozen=True)
class CalibrationRow:
    """A spec value the recording calibrated (DIAG.json `verdict.calibration`)."""

    parameter: str
    spec_value: float
    fitted: float
    sd: float
    unit: str
    share: float = Settings.calibration_share
    scale: float = 0.0  # what `share` is of where the spec says 0 (SpecGlobal.fallback)
    tolerance: tuple[float, float] | None = None  # SpecGlobal.tolerance
    # What a fit of the search asked for this value beyond its tolerance, before it was
    # held within it while the search ran (tolerance.py; NaN: none did).
    asked: float = math.nan
    reference: float = math.nan  # what the tolerance is about, if not the spec's value
    bounds: tuple[float, float] | None = None  # the range the calibration may move it in

    @property
    def at_range_end(self) -> bool:
        """Moved to an end of the range the calibration may move it in (within a thousandth of
        its scale, as tolerance.pinned), other than a physical 0 (a sharp orifice, no drag):
        the recording asks for more than a spec's value may give, so the value is no
        estimate, and its σ (a bound's) no error bar: a finding, not a calibration."""
        if self.bounds is None or not self.moved:
            return False
        size = abs(self.spec_value) or self.scale
        return any(end != 0 and at_bound(self.fitted, end, size) for end in self.bounds)

    @property
    def finding(self) -> bool:
        """Not a spec's error: beyond its tolerance, or at an end of its range."""
        return self.beyond or self.at_range_end

    @property
    def beyond(self) -> bool:
        """Moved further from the spec's value than a real damper departs from its
        drawing (SpecGlobal.tolerance): a finding, not a calibration."""
        if self.tolerance is None or self.spec_value <= 0 or not self.moved:
            return False
        ratio = self.fitted / self.about
        return not self.tolerance[0] <= ratio <= self.tolerance[1]

    @property
    def written(self) -> bool:
        """The recording gives the value itself (a gas charge the operator wrote down),
        other than the spec's: the calibration is then about the recording's value."""
        ref = self.reference
        return math.isfinite(ref) and ref > 0 and ref != self.spec_value

    @property
    def about(self) -> float:
        """What the calibration moved the value from: the recording's where it gives one
        (`written`), else the spec's."""
        return self.reference if self.written else self.spec_value

    @property
    def moved(self) -> bool:
        """Worth a sentence: off the value it is about (`about`: the spec's, or the
        recording's own) by more than `share` of it (of `scale` where the spec gives 0: a
        bleed land of 0.1 mm is a sharp orifice still) and by more than three of its σ. A
        charge fitted at the one the recording was charged to is no calibration, however
        far the drawing's is."""
        off = abs(self.fitted - self.about)
        sd = self.sd if math.isfinite(self.sd) else 0.0
        size = abs(self.about) or self.scale
        return off > self.share * size and off > 3 * sd


@dataclass
class TestScore:
    index: int
    clicks: int
    frequency_hz: float
    e_t_before: float
    e_t_after: float


@dataclass(frozen=True)
class ShortTest:
    """A test of fewer than two whole cycles: it has no cycle-to-cycle scatter, so no noise
    to weigh a mismatch against, and the diagnosis claims nothing from it."""

    index: int
    clicks: int
    frequency_hz: float
    cycles: float


@dataclass
class Diagnosis:
    mismatch: MismatchStat
    location: Location
    trials: list[Trial]
    claimed: list[str]
    indistinguishable: list[Indistinguishable]  # claimed terms the data cannot tell apart
    unexplained: Location
    remaining: MismatchStat
    tests: list[TestScore]
    baseline: Fitted
    final: Fitted
    data: Data
    notes: list[str]
    wall_s: float
    single_frequency: bool
    calibration: list[CalibrationRow] = field(default_factory=list)
    settings: Settings = field(default_factory=Settings)  # what the search used; the verdict too
    sensor: list[str] = field(default_factory=list)  # faults of the sensors, not physics
    short_tests: list[ShortTest] = field(default_factory=list)  # left out, see ShortTest
    # What the search left (significant), described, with a discovered term (discover.py)
    described: list[Described] = field(default_factory=list)
    # Spec values held within their tolerance in the baseline `mismatch` is measured on
    # (diagnose/tolerance.py): what the spec leaves within what a damper departs from its
    # drawing by, which the search was offered.
    held: tuple[str, ...] = ()

    @property
    def alpha(self) -> float:
        return self.settings.alpha

    @property
    def testable(self) -> bool:
        """False when every test was short: no mismatch test, nothing claimed (_untestable)."""
        return not math.isnan(self.mismatch.p_value)
