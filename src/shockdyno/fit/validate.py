"""Validation: E_t, E_x, E_ẋ of every test for the proposed model and Talbott's, and the
per-frequency table (the paper's Table 4).

Errors are computed on every measured sample (the full rate, not the fit's decimated
objective samples), with the velocity and acceleration the model was fed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from rich.table import Table

from shockdyno.errors import FitError
from shockdyno.fit.metrics import error_metrics
from shockdyno.fit.prepare import PreparedTest
from shockdyno.fit.problem import prepared_inputs
from shockdyno.fit.result import FitResult, TestValidation
from shockdyno.fit.result_doc import Table4Doc
from shockdyno.model.composite import DamperModel
from shockdyno.record.types import TestData

FloatArray = NDArray[np.float64]
METRICS = ("E_t", "E_x", "E_xd")


@dataclass(frozen=True)
class ModelForces:
    """One test's measured channels and both models' forces on its measured cycles."""

    test: TestData
    v: FloatArray
    a: FloatArray
    proposed: FloatArray
    talbott: FloatArray


def click_areas(
    result: FitResult, clicks: int, gas_clicks: int, setting: tuple[tuple[str, int], ...] = ()
) -> tuple[float, float, float]:
    """(A_bc, A_bt, A_b Talbott) fitted for this click setting (`setting`: every
    adjuster's clicks of a damper with several, sorted by name)."""
    for c in result.clicks:
        if c.clicks == clicks and c.gas_clicks == gas_clicks and c.setting == setting:
            return c.a_bc_m2, c.a_bt_m2, c.a_b_talbott_m2
    at = ", ".join(f"{n} {v}" for n, v in setting) if setting else f"{clicks} clicks"
    raise FitError(f"the fit has no result for {at} (gas {gas_clicks})")


def model_forces(
    model: DamperModel, result: FitResult, prepared: Sequence[PreparedTest]
) -> list[ModelForces]:
    """Both models on every measured sample (full rate), each test its own segment."""
    out = []
    for p in prepared:
        m = p.data.meta
        a_bc, a_bt, a_b = click_areas(result, m.clicks, m.gas_clicks, m.setting)
        inputs = prepared_inputs([p], full_rate=True)
        out.append(
            ModelForces(
                test=p.data,
                v=p.v,
                a=p.a,
                proposed=model.force(inputs, a_bc, a_bt),
                talbott=model.force(inputs, a_b, a_b),
            )
        )
    return out


def validate_tests(
    model: DamperModel, result: FitResult, prepared: Sequence[PreparedTest]
) -> list[TestValidation]:
    """The `tests[]` entries of the fit JSON."""
    return scores(model_forces(model, result, prepared))


def scores(forces: Sequence[ModelForces]) -> list[TestValidation]:
    """The `tests[]` entries of the fit JSON from both models' forces on each test."""
    rows = []
    for mf in forces:
        d, m = mf.test, mf.test.meta
        scores: dict[str, dict[str, float]] = {}
        for name, f_model in (("proposed", mf.proposed), ("talbott", mf.talbott)):
            e = error_metrics(d.t, d.x, d.force, f_model, v=mf.v, a=mf.a)
            e["mean_abs_error_n"] = float(np.mean(np.abs(f_model - d.force)))
            scores[name] = {k: float(v) for k, v in e.items()}
        temp = (
            float(np.nanmean(d.temperature))
            if d.temperature is not None and np.any(np.isfinite(d.temperature))
            else None
        )
        rows.append(
            TestValidation(
                index=m.index,
                clicks=m.clicks,
                gas_clicks=m.gas_clicks,
                adjusters=dict(m.adjusters),
                frequency_hz=m.frequency_hz,
                motion=m.motion,
                n_samples=int(d.t.size),
                duration_s=float(d.t[-1] - d.t[0]),
                temperature_mean_c=temp,
                proposed=scores["proposed"],
                talbott=scores["talbott"],
            )
        )
    return rows


@dataclass(frozen=True)
class Table4Row:
    """Averages over the tests at one frequency; enhancement = (Talbott - proposed) / Talbott."""

    frequency_hz: float
    n_tests: int
    proposed: dict[str, float]
    talbott: dict[str, float]
    enhancement_pct: dict[str, float]

    def doc(self) -> Table4Doc:
        """FIT.json's `info.table4[]` entry (a number not finite written as null)."""

        def safe(d: dict[str, float]) -> dict[str, float | None]:
            return {k: v if math.isfinite(v) else None for k, v in d.items()}

        return Table4Doc(
            frequency_hz=self.frequency_hz,
            n_tests=self.n_tests,
            proposed=safe(self.proposed),
            talbott=safe(self.talbott),
            enhancement_pct=safe(self.enhancement_pct),
        )


def table4(result: FitResult) -> list[Table4Row]:
    """Per frequency (rounded to 1 mHz), mean errors of both models and the enhancement %."""
    groups: dict[float, list[TestValidation]] = {}
    for t in result.tests:
        groups.setdefault(round(t.frequency_hz, 3), []).append(t)
    rows = []
    for f in sorted(groups):
        ts = groups[f]
        prop = {k: float(np.mean([t.proposed[k] for t in ts])) for k in METRICS}
        tal = {k: float(np.mean([t.talbott[k] for t in ts])) for k in METRICS}
        enh = {
            k: (100.0 * (tal[k] - prop[k]) / tal[k] if tal[k] > 0 else math.nan) for k in METRICS
        }
        rows.append(Table4Row(f, len(ts), prop, tal, enh))
    return rows


TABLE4_HEADER = ["Frequency (Hz)", "Model", "E_t", "E_x", "E_ẋ"]


def table4_rows(result: FitResult) -> tuple[list[str], list[list[str]]]:
    """(header, rows) of text laid out like the paper's Table 4: per frequency three rows,
    Proposed, Talbott and Enhancement (%). For printing and for the report."""
    rows: list[list[str]] = []
    for r in table4(result):
        freq = f"{r.frequency_hz:g} ({r.n_tests} tests)"
        rows.append([freq, "Proposed", *(f"{r.proposed[k]:.4g}" for k in METRICS)])
        rows.append(["", "Talbott", *(f"{r.talbott[k]:.4g}" for k in METRICS)])
        rows.append(["", "Enhancement (%)", *(f"{r.enhancement_pct[k]:.4g}" for k in METRICS)])
    return list(TABLE4_HEADER), rows


def table4_table(result: FitResult) -> Table:
    """A rich Table of `table4_rows`, one section per frequency."""
    table = Table(title="Errors by frequency (paper's Table 4): proposed vs Talbott")
    header, rows = table4_rows(result)
    for i, name in enumerate(header):
        table.add_column(name, justify="left" if i == 1 else "right")
    for i, row in enumerate(rows):
        table.add_row(*row, end_section=i % 3 == 2)
    return table
