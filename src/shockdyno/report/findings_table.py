"""The findings table of a diagnosis, one renderer for every place it is shown: the
`diagnose` terminal (which picks its columns), `diagnose --report`'s page and the report's
diagnosis section. Cells from DIAG.json's rows (report/documents.py `Finding`); forces,
lengths, speeds and temperatures in the reader's units."""

from __future__ import annotations

import math

from shockdyno.fit.result_doc import EstimateDoc
from shockdyno.report.documents import Finding
from shockdyno.report.html import Page
from shockdyno.units import SI, Units, in_units

FINDING_COLUMNS = (
    "round",
    "physics",
    "claimed",
    "p",
    "held-out gain",
    "peak effect",
    "parameters (± 1σ)",
    "alike",
    "why not",
)
_NUMERIC = (True, False, False, True, True, True, False, False, False)


def number_text(value: float | None, spec: str = ".3g") -> str:
    """A number as text; '–' for none, or one that is not finite (a hand-edited NaN)."""
    return format(value, spec) if value is not None and math.isfinite(value) else "–"


def _in_units(unit: str, units: Units) -> tuple[float, float, str]:
    """(scale, offset, label) of a parameter stored in SI ``unit``, shown in ``units``: the
    forces, lengths, speeds, damping coefficients and temperatures the units module converts;
    anything else (Pa, s, 1/K, ...) and everything in SI as stored."""
    if not units.imperial:
        return 1.0, 0.0, unit
    fn, ln, vn = units.force_per_n, units.length_per_m, units.velocity_per_m_s
    zero = units.temperature(0.0)  # °C is affine: a spread (sd) takes the scale only
    return {
        "N": (fn, 0.0, units.force_label),
        "m": (ln, 0.0, units.length_label),
        "m/s": (vn, 0.0, units.velocity_label),
        "N·s/m": (fn / ln, 0.0, f"{units.force_label}·s/{units.length_label}"),
        "°C": (units.temperature(1.0) - zero, zero, units.temperature_label),
    }.get(unit, (1.0, 0.0, unit))


def parameters_text(value: dict[str, EstimateDoc], units: Units = SI) -> str:
    """A finding's parameters: "breakaway_n = 24 ± 0.4 N; ...", in ``units``."""
    out = []
    for name, p in value.items():
        scale, offset, label = _in_units(p.unit, units)
        shown = None if p.value is None else p.value * scale + offset
        unit = f" {label}" if label else ""
        sd = number_text(None if p.sd is None else p.sd * scale, ".2g")  # a spread: no offset
        out.append(f"{name} = {number_text(shown, '.4g')} ± {sd}{unit}")
    return "; ".join(out) or "–"


def finding_cells(f: Finding, u: Units = SI) -> tuple[str, ...]:
    """A DIAG.json finding as the findings table shows it (FINDING_COLUMNS; the peak
    effect in `u`'s force unit)."""
    return (
        str(f.round),
        f.physics,
        "yes" if f.claimed else "",
        number_text(f.p_value, ".3g"),
        number_text(f.heldout_gain, ".2f"),  # '–': not scored held out
        number_text(None if f.effect_peak_n is None else u.force(f.effect_peak_n), ".3g"),
        parameters_text(f.parameters, u),
        ", ".join(f.ambiguous_with),
        in_units(f.why_not, u),
    )


def finding_headers(u: Units = SI) -> list[str]:
    return [c if c != "peak effect" else f"{c} ({u.force_label})" for c in FINDING_COLUMNS]


def render_findings(page: Page, findings: tuple[Finding, ...], units: Units = SI) -> None:
    """The table on a page, a term not claimed greyed."""
    page.table(
        finding_headers(units),
        [list(finding_cells(f, units)) for f in findings],
        row_classes=["" if f.claimed else "dim" for f in findings],
        numeric=_NUMERIC,
    )
