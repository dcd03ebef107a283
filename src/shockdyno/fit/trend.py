"""Bleed area against clicks: a polynomial like the paper's eq. 9-10, degree chosen by AICc.

Only identifiable per-click values enter the trend (an area the data cannot pin would
drag it anywhere). The fit is unweighted: per-click scatter on a real damper is larger
than each value's own uncertainty (the paper's Fig. 12), so 1/σ² weights would let the
few sharpest clicks dictate the curve. Degrees 0 up to 4 (or fewer with few points) are
compared by the corrected Akaike criterion
    AICc = n ln(RSS/n) + 2k + 2k(k+1)/(n-k-1),  k = degree + 1,
which stops adding terms once they no longer pay for themselves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Annotated

import numpy as np
from msgspec import Meta
from numpy.typing import ArrayLike

from shockdyno.schema import OMITTED_AT_DEFAULT, Table, convert, to_json

MAX_DEGREE = 4


def polynomial_trend(clicks: ArrayLike, areas: ArrayLike) -> AreaTrend | None:
    """{degree, coefficients (highest power first, for numpy.polyval), ...} or None."""
    n_arr = np.asarray(clicks, dtype=float)
    y = np.asarray(areas, dtype=float)
    n = n_arr.size
    if n == 0:
        return None
    if n < 4:  # too few points to compare degrees: a line (or a constant)
        degree = min(1, n - 1)
        coef = np.polyfit(n_arr, y, degree) if n > 1 else np.array([y[0]])
        return _describe(coef, n_arr, y, "fewer than 4 clicks: straight line")
    scale = max(float(np.max(np.abs(y))), 1e-30)
    best: tuple[float, np.ndarray] | None = None
    for degree in range(0, min(MAX_DEGREE, n - 3) + 1):
        coef = np.polyfit(n_arr, y, degree)
        rss = float(np.sum((np.polyval(coef, n_arr) - y) ** 2)) + n * (1e-9 * scale) ** 2
        k = degree + 1
        aicc = n * math.log(rss / n) + 2 * k + 2 * k * (k + 1) / (n - k - 1)
        if best is None or aicc < best[0] - 1e-9:
            best = (aicc, coef)
    assert best is not None
    return _describe(best[1], n_arr, y, "AICc")


@dataclass(frozen=True)
class AreaTrend:
    """A bleed area against rod clicks: polynomial coefficients (highest power first)."""

    degree: int
    coefficients: tuple[float, ...]
    clicks_used: tuple[int, ...]
    rms_m2: float
    r2: float
    selection: str
    gas_clicks: int = 0
    # The adjuster whose clicks it is against, on a damper with several ("": the one rod)
    adjuster: str = ""

    def at(self, clicks: float) -> float:
        return float(np.polyval(self.coefficients, clicks))

    def to_json(self) -> Table:
        """FIT.json's entry (`TrendDoc`)."""
        out: Table = to_json(TrendDoc.of(self))
        return out

    @staticmethod
    def from_json(d: Table) -> AreaTrend:
        """A trend from its JSON (FIT.json's `trend` entries; tests build them so)."""
        return convert(d, TrendDoc, "trend", unknown_keys=True).trend()


def nan(v: float | None) -> float:
    """A JSON number that may be null (JSON has no NaN) as a float."""
    return math.nan if v is None else float(v)


@dataclass(frozen=True, kw_only=True)
class TrendDoc:
    """FIT.json's `trend.A_bc` / `trend.A_bt` (fit/result_doc.py): written in this order."""

    degree: int | None = None  # read for the record: the coefficients say it
    coefficients: Annotated[list[float], Meta(min_length=1)]  # highest power first
    clicks_used: list[int] = field(default_factory=list)
    rms_m2: float | None = None
    r2: float | None = None
    selection: str = ""
    gas_clicks: int = 0
    adjuster: str = field(default="", metadata=OMITTED_AT_DEFAULT)  # one adjuster's line

    @staticmethod
    def of(t: AreaTrend) -> TrendDoc:
        return TrendDoc(
            degree=t.degree,
            coefficients=list(t.coefficients),
            clicks_used=list(t.clicks_used),
            rms_m2=t.rms_m2,
            r2=t.r2,
            selection=t.selection,
            gas_clicks=t.gas_clicks,
            adjuster=t.adjuster,
        )

    def trend(self) -> AreaTrend:
        coef = tuple(float(c) for c in self.coefficients)
        return AreaTrend(
            degree=len(coef) - 1,
            coefficients=coef,
            clicks_used=tuple(self.clicks_used),
            rms_m2=nan(self.rms_m2),
            r2=nan(self.r2),
            selection=self.selection,
            gas_clicks=self.gas_clicks,
            adjuster=self.adjuster,
        )


def _describe(coef: np.ndarray, n: np.ndarray, y: np.ndarray, selection: str) -> AreaTrend:
    fit = np.polyval(coef, n)
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    ss_res = float(np.sum((fit - y) ** 2))
    return AreaTrend(
        degree=int(coef.size - 1),
        coefficients=tuple(float(c) for c in coef),
        clicks_used=tuple(round(float(c)) for c in n),
        rms_m2=math.sqrt(ss_res / n.size),
        r2=1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0,
        selection=selection,
    )
