"""FIT.json's shape, read through shockdyno.schema (keys as the file spells them).

Every key a reader relies on is typed here; keys added by later versions are ignored
(a result outlives the code that wrote it), and a missing optional key takes the value
older fits implied. JSON has no NaN: a value that may be absent or non-finite is
`float | None`, None read back as NaN.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

from msgspec import Meta

from shockdyno.fit.trend import TrendDoc, nan
from shockdyno.model.params import Estimate
from shockdyno.result_files import read_result
from shockdyno.schema import convert

Clicks = Annotated[int, Meta(ge=0)]


@dataclass(frozen=True)
class ClickDoc:
    clicks: Clicks
    A_bc_m2: float
    A_bt_m2: float
    A_b_talbott_m2: float
    gas_clicks: Clicks = 0
    A_bc_sd_m2: float | None = None
    A_bt_sd_m2: float | None = None
    A_b_talbott_sd_m2: float | None = None
    identifiable_bc: bool = True
    identifiable_bt: bool = True
    objective_n: float | None = None
    objective_talbott_n: float | None = None
    bleed_share_bc: float | None = None
    bleed_share_bt: float | None = None
    adjusters: dict[str, Clicks] = field(default_factory=dict)


@dataclass(frozen=True)
class TestDoc:
    __test__ = False  # not a pytest class

    index: int
    clicks: int
    frequency_hz: float
    gas_clicks: int = 0
    motion: str = "sine"
    n_samples: int = 0
    duration_s: float = 0.0
    temperature_mean_C: float | None = None
    proposed: dict[str, float | None] = field(default_factory=dict)
    talbott: dict[str, float | None] = field(default_factory=dict)
    adjusters: dict[str, Clicks] = field(default_factory=dict)


@dataclass(frozen=True)
class EstimateDoc:
    value: float | None  # None: not finite (an infinite off value)
    sd: float | None = None
    unit: str = ""
    fixed: bool = False
    at_bound: bool = False

    def estimate(self) -> Estimate:
        return Estimate(nan(self.value), nan(self.sd), self.unit, self.fixed, self.at_bound)


@dataclass(frozen=True)
class FitDoc:
    spec_path: str
    globals: dict[str, float]
    clicks: list[ClickDoc]
    trend: dict[str, TrendDoc] = field(default_factory=dict)
    tests: list[TestDoc] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)  # free-form: docs/fit.md
    terms: dict[str, dict[str, EstimateDoc]] = field(default_factory=dict)


def read_fit_doc(path: Path, flag: str) -> FitDoc:
    """FIT.json at `path`, typed; a recording, a DIAG.json or a garbled value is one
    ConfigError line naming `flag`, the file and the key."""
    doc = read_result(path, flag, "fit")
    return convert(doc, FitDoc, f"{flag}: {path}", unknown_keys=True)
