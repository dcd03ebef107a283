"""The click chart at a reference oil temperature: a correction by the fitted model.

A damper warms as it is swept, so clicks measured late in a sweep read softer than the
same clicks cold. Where the recording has a temperature channel and the fit has the
``thermal`` term, each measured value is moved to the reference temperature by what the
fitted model says that temperature does at that click and velocity:

    F_ref = G(T_ref) + (F_measured − G(T)) × D(T_ref) / D(T)

with T the mean oil temperature of the click's tests over their measured cycles, G(T)
the model's static force (x = 0, v = 0: the gas force on the rod) and D(T) = F(T) − G(T)
the model's damping force at that velocity (mid-stroke, zero acceleration, the click's
fitted areas). The damping part is scaled, the gas part moved. A plain ratio
F_measured × F(T_ref) / F(T) would be the same where the gas force is small, but the gas
force puts a zero of F inside the chart (the reference damper's rebound at 21 clicks and
25 mm/s: −1.1 N at 20 °C, +14.8 N at 40 °C), and a ratio through zero scales a measured
value by −13. At T_ref = T the correction is the identity.

It is only as good as the thermal term: what the term does not model (a shim stack's
viscosity dependence unless ``thermal.damping_coeff_per_k`` was fitted) is not corrected.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from shockdyno.atomic import write_text_atomic
from shockdyno.errors import ConfigError, FitError
from shockdyno.fit.forces import setting_temperatures as of_settings
from shockdyno.model.composite import ModelInputs
from shockdyno.record.types import TestData
from shockdyno.report import clickchart
from shockdyno.report.html import Page
from shockdyno.units import SI, Units

if TYPE_CHECKING:
    from shockdyno.fit.result import FitResult

DEFAULT_REFERENCE_C = 40.0
# The thermal term's own range for its reference temperature: oil outside it is not in a
# damper that is working (or the number is in °F or K).
MIN_REFERENCE_C, MAX_REFERENCE_C = -40.0, 150.0

Setting = clickchart.Setting


def reference_c(text: str | float) -> float:
    """--reference-temperature-c as a number, or a one-line ConfigError (checked by the
    command, not by argparse, whose error carries the whole usage)."""
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(f"--reference-temperature-c: a temperature in °C, not {text!r}") from None
    if not MIN_REFERENCE_C <= value <= MAX_REFERENCE_C:
        raise ConfigError(
            f"--reference-temperature-c: an oil temperature from {MIN_REFERENCE_C:g} to "
            f"{MAX_REFERENCE_C:g} °C, not {text}"
        )
    return value


def add_argument(parser: argparse.ArgumentParser) -> None:
    """--reference-temperature-c T; read back with reference_c(args.reference_temperature_c)."""
    parser.add_argument(
        "--reference-temperature-c",
        default=DEFAULT_REFERENCE_C,
        metavar="T",
        help="oil temperature of the temperature-corrected click chart (needs a temperature "
        "channel and a fit with the thermal term)",
    )


@dataclass(frozen=True)
class CorrectedChart:
    reference_c: float
    velocities_m_s: tuple[float, ...]
    temperatures_c: dict[Setting, float]  # mean oil temperature of each setting's tests
    measured: dict[Setting, dict[float, float]]
    corrected: dict[Setting, dict[float, float]]
    extrapolated: dict[Setting, dict[float, bool]] = field(default_factory=dict)


def setting_temperatures(tests: Sequence[TestData]) -> dict[Setting, float]:
    """Mean temperature over the measured cycles of each setting's complete tests (each
    test weighted alike, as the click chart averages them); settings without a reading
    are left out."""
    # the fit saves the model at the same temperatures (fit/forces.py): its one definition
    return of_settings(tests)


def why_not(tests: Sequence[TestData], fit: FitResult | None) -> str:
    """Why there is no corrected chart ("" when there is one)."""
    if fit is None or "thermal" not in {t.name for t in fit.model().vehicle().terms}:
        what = "no fit" if fit is None else "a fit without the thermal term"
        return (
            f"No temperature-corrected click chart: the report has {what}, so no model of "
            "how force depends on oil temperature (fit with --terms thermal to have one)."
        )
    if not setting_temperatures(tests):
        return "No temperature-corrected click chart: the recording has no temperature channel."
    return ""


def model_forces_at(
    fit: FitResult, key: Setting, velocities: Sequence[float], temperature_c: float
) -> tuple[float, np.ndarray]:
    """(static force G, forces F at the velocities) of the car's model at one oil
    temperature: mid-stroke, zero acceleration, each point its own state. As the fit saved
    them (`fit.saved`, fit/forces.py: the recording's temperatures and the default
    reference), else computed."""
    a_bc, a_bt = fit.areas(key[0], gas_clicks=key[1])
    t = float(temperature_c)
    force = fit.saved.at_temperature(a_bc, a_bt, t, velocities) if fit.saved else None
    if force is None:
        v = np.concatenate([[0.0], np.asarray(velocities, dtype=float)])
        zeros = np.zeros(v.size)
        inputs = ModelInputs.points(zeros, v, zeros, np.full(v.size, t))
        force = fit.model().vehicle().force(inputs, a_bc, a_bt)
    return float(force[0]), np.asarray(force[1:], dtype=float)


def correct(
    measured: dict[Setting, dict[float, float]],
    temperatures_c: dict[Setting, float],
    fit: FitResult,
    reference_c: float,
    damping_only: bool = False,
) -> dict[Setting, dict[float, float]]:
    """The measured values moved to ``reference_c`` (module docstring); a setting the fit
    has no areas for, or without a temperature, is left out. ``damping_only``: the values
    are damping force (the gas force already removed), scaled by D(T_ref) / D(T) alone."""
    out: dict[Setting, dict[float, float]] = {}
    for key, row in measured.items():
        if key not in temperatures_c:
            continue
        targets = list(row)
        try:
            g_t, f_t = model_forces_at(fit, key, targets, temperatures_c[key])
            g_ref, f_ref = model_forces_at(fit, key, targets, reference_c)
        except FitError:
            continue
        d_t, d_ref = f_t - g_t, f_ref - g_ref
        corrected = {}
        for k, v in enumerate(targets):
            value = row[v]
            ok = math.isfinite(value) and abs(d_t[k]) > 1e-9
            if not ok:
                corrected[v] = math.nan
            elif damping_only:
                corrected[v] = value * d_ref[k] / d_t[k]
            else:
                corrected[v] = g_ref + (value - g_t) * d_ref[k] / d_t[k]
        out[key] = corrected
    return out


def corrected_chart(
    tests: Sequence[TestData],
    fit: FitResult,
    reference_c: float,
    raw_force: bool = True,
    speeds_m_s: Sequence[float] = clickchart.STANDARD_VELOCITIES_M_S,
) -> CorrectedChart:
    """``raw_force``: correct the force as measured (gas force included); else the click
    chart's damping force (its gas force removed), scaled by the model's damping ratio."""
    chart = clickchart.click_chart(tests, None, speeds_m_s, raw_force=raw_force)
    measured = {k: {v: r.force_n for v, r in row.items()} for k, row in chart.measured.items()}
    extrapolated = {
        k: {v: r.extrapolated for v, r in row.items()} for k, row in chart.measured.items()
    }
    temps = setting_temperatures(tests)
    return CorrectedChart(
        reference_c,
        chart.velocities_m_s,
        temps,
        measured,
        correct(measured, temps, fit, reference_c, damping_only=not raw_force),
        extrapolated,
    )


CSV_NAME = "click_chart_reference.csv"
CSV_HEADER = [
    "clicks",
    "gas_clicks",
    "velocity_m_s",
    "temperature_c",
    "reference_c",
    "measured_n",
    "corrected_n",
    "extrapolated",  # 1: the measured value is the click chart's extrapolation (its *)
]


def to_csv(c: CorrectedChart) -> str:
    """Long format, one row per setting and velocity (velocity signed, + compression)."""
    text = io.StringIO()
    w = csv.writer(text, lineterminator="\n")
    w.writerow(CSV_HEADER)
    for key, row in sorted(c.corrected.items()):
        for v in c.velocities_m_s:
            cells = (c.measured[key][v], row[v])
            values = [f"{f:.2f}" if math.isfinite(f) else "" for f in cells]
            temp = f"{c.temperatures_c[key]:.2f}"
            ext = int(c.extrapolated.get(key, {}).get(v, False))
            w.writerow([*key, f"{v:g}", temp, f"{c.reference_c:g}", *values, ext])
    return text.getvalue()


EXTRAPOLATION_K = 15.0  # a reference further than this from every test is flagged


def _caveats(c: CorrectedChart) -> list[str]:
    """What a reader must know before trusting the table: a reference far outside the
    tested temperatures, a thermal term that moves nothing."""
    notes = []
    temps = list(c.temperatures_c.values())
    gap = min(abs(c.reference_c - t) for t in temps)
    if gap > EXTRAPOLATION_K:
        notes.append(
            f"The reference is {gap:.0f} K from the nearest tested oil temperature "
            f"({min(temps):.1f} to {max(temps):.1f} °C): the thermal term is extrapolated "
            "that far beyond what this recording shows."
        )
    moved = [
        abs(row[v] - c.measured[key][v])
        for key, row in c.corrected.items()
        for v in row
        if math.isfinite(row[v]) and math.isfinite(c.measured[key][v])
    ]
    if moved and max(moved) < 0.5:
        notes.append(
            f"The correction moves no value by as much as 0.5 N (largest {max(moved):.2g} N): "
            "the fit's thermal term has no force change with temperature (see the fit's "
            "thermal parameters, e.g. at a bound of 0), so these are the measured values."
        )
    return notes


def _table(c: CorrectedChart, gas: bool, units: Units) -> tuple[list[str], list[list[str]]]:
    """The corrected chart's header and rows: a setting a row, its tests' mean temperature,
    the corrected force at each velocity (* where the measured value was extrapolated)."""
    header = [
        "clicks",
        *(["gas"] if gas else []),
        f"T test ({units.temperature_label})",
        *(clickchart.velocity_label(v, units) for v in c.velocities_m_s),
    ]
    rows = []
    for key, row in sorted(c.corrected.items()):
        t_c = units.temperature(c.temperatures_c[key])
        cells = [str(key[0]), *([str(key[1])] if gas else []), f"{t_c:.1f}"]
        star = c.extrapolated.get(key, {})
        cells += [
            f"{units.force(row[v]):.0f}{'*' if star.get(v) else ''}"
            if math.isfinite(row[v])
            else "–"
            for v in c.velocities_m_s
        ]
        rows.append(cells)
    return header, rows


def render(
    page: Page,
    tests: Sequence[TestData],
    fit: FitResult | None,
    reference_c: float,
    out_dir: Path | None = None,
    raw_force: bool = True,
    units: Units = SI,
    adjuster: str = "",
) -> None:
    """The section after the click chart: the corrected chart (and, given ``out_dir``, its
    CSV there, SI), or one line saying why there is none; the page's numbers in ``units``.
    ``adjuster``: one adjuster's line of a damper with several (its own CSV and heading)."""
    reason = why_not(tests, fit)
    tl = units.temperature_label
    csv_name = CSV_NAME.replace(".csv", f"_{adjuster}.csv") if adjuster else CSV_NAME

    def temp(t_c: float, spec: str = "g") -> str:
        return f"{units.temperature(t_c):{spec}} {tl}"

    heading = f"Click chart at {temp(reference_c)} oil" + (
        f": {adjuster} adjuster" if adjuster else ""
    )
    if reason or fit is None:
        page.paragraph(reason)  # in the click chart's section: one line, no heading
        if out_dir is not None:  # a re-run's page must not sit beside an earlier one's CSV
            (Path(out_dir) / csv_name).unlink(missing_ok=True)
        return
    c = corrected_chart(tests, fit, reference_c, raw_force, units.standard_velocities_m_s)
    formula = (
        "F = G(T_ref) + (F_measured − G(T)) × D(T_ref) / D(T)"
        if raw_force
        else "D = D_measured × D_model(T_ref) / D_model(T) (damping force, the gas force "
        "removed as in the table above)"
    )
    temps = sorted(c.temperatures_c.values())
    page.section(
        heading,
        "A model-based correction, not a measurement: each measured value (the table above) "
        f"moved from its tests' mean oil temperature to {temp(reference_c)} by the fitted "
        f"thermal term: {formula}, with G the model's static (gas) force and D its damping "
        "force at that click and velocity. "
        f"Tests' mean temperatures: {temp(temps[0], '.1f')} to {temp(temps[-1], '.1f')}; "
        f"reference {temp(reference_c)} (--reference-temperature-c, °C). Only what the "
        "thermal term models is corrected.",
    )
    for note in _caveats(c):
        page.paragraph(note, warn=True)
    gas = len({g for _, g in c.measured}) > 1
    header, rows = _table(c, gas, units)
    page.subheading(
        f"Corrected to {temp(reference_c)} "
        f"({units.force_label}; velocity in {units.velocity_label})"
    )
    page.table(header, rows, numeric=[True] * len(header))
    if out_dir is not None:
        write_text_atomic(Path(out_dir) / csv_name, to_csv(c))
        page.link(csv_name, csv_name, ": measured and corrected values, with the temperatures.")
    left_out = sorted(set(c.measured) - set(c.corrected))
    if left_out:
        page.paragraph(
            "Not corrected (no temperature reading or no fitted areas): clicks "
            + ", ".join(f"{k[0]}" + (f"/{k[1]}" if gas else "") for k in left_out)
            + "."
        )
