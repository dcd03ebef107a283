"""The report's diagnose section, rendered from the DIAG.json of `shockdyno diagnose`.

The document is read and checked once (`report/documents.py`: `DiagnosisDoc`), so here
every key is there with its type; what an older file lacks comes as the default that shows
nothing. Shown:

- ``mismatch``: whether it is significant (or not tested), p, noise floor, structured
  share, and its regions ``where``
- ``findings``: each candidate term, its parameters in the page's units, greyed unless
  claimed: the cells of the terminal and diagnose's own page (report/findings_table.py)
- ``verdict``: its words in SI or in imperial units (``text_imperial`` is newer: an older
  file's page in imperial shows ``text`` and says its numbers are SI), the physics named,
  the regions still unexplained and, newer, what is left described with a discovered
  term and its figure (report/unexplained_section.py)
- ``tests``: E_t per test before and after the named physics
- ``info.spec``: the damper spec the diagnosis started from
- ``info.figures``: the PNGs `diagnose --report DIR` drew, relative to the JSON's folder;
  copied into the report's directory (`render_figures`), with ``info.figures_units``

To show a new key, describe it in documents.py, add a ``_render_<key>`` function and call
it from ``render_diagnose``. Forces, lengths, speeds and temperatures are shown in the page's
`Units`; speeds in SI stay in m/s, as the verdict's own words give them. Other parameters
(Pa, s, 1/K, ...) as stored.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TypeGuard

from shockdyno.report.documents import (
    DiagnosisDoc,
    Finding,
    Mismatch,
    Region,
    ScoredTest,
    SpecUsed,
    Verdict,
)
from shockdyno.report.findings_table import number_text as _num
from shockdyno.report.findings_table import render_findings
from shockdyno.report.html import Page, shown_path
from shockdyno.report.unexplained_section import render_unexplained
from shockdyno.units import SI, Units


def _finite(value: float | None) -> TypeGuard[float]:
    return value is not None and math.isfinite(value)


def _join(items: Iterable[str]) -> str:
    return ", ".join(items) or "–"


def _range(value: tuple[float, float], scale: float, unit: str) -> str:
    lo, hi = value
    return f"{lo * scale:.3g} to {hi * scale:.3g} {unit}"


def _times(value: float | None, scale: float) -> float | None:
    """A number of DIAG.json scaled into display units."""
    return None if value is None else value * scale


def _speed(units: Units) -> tuple[float, str]:
    """Scale and label of a speed: m/s in SI, as the verdict's own words give it; in/s."""
    return (units.velocity_per_m_s, units.velocity_label) if units.imperial else (1.0, "m/s")


def _render_verdict(page: Page, verdict: Verdict, units: Units) -> None:
    imperial = verdict.text_imperial
    if units.imperial and imperial is not None and imperial.strip():
        page.paragraph(imperial.strip())
    elif verdict.text.strip():
        page.paragraph(verdict.text.strip())
        if units.imperial:  # a DIAG.json older than text_imperial: its words are SI only
            page.paragraph(
                "The verdict above is in the diagnosis's own words, in SI units (N, mm, m/s): "
                "its DIAG.json predates the imperial text. The tables below are converted."
            )
    page.paragraph(f"Physics named: {_join(verdict.physics)}.")
    if verdict.unexplained:
        regions = [r for u in verdict.unexplained for r in (u.regions or (u,))]
        page.paragraph(
            "Still unexplained: " + "; ".join(region_text(r, units) for r in regions) + ".",
            warn=True,
        )
        render_unexplained(page, verdict.unexplained, units)  # described, with its form


def region_text(r: Region, units: Units = SI) -> str:
    """A region of DIAG.json in words: "in rebound at 15.6 to 29.2 mm, -0.097 to -0.036 m/s,
    near reversal (1, 1.5 Hz; 25 % of the structure; 19 N RMS)", in ``units``. (A region as
    a dict is read as DIAG.json would hold it.)"""
    x = _range(r.x_range_m, units.length_per_m, units.length_label)
    where = [
        f"in {r.stroke} at {x}",
        _range(r.v_range_m_s, *_speed(units)),
        *(["near reversal"] if r.near_reversal else []),
    ]
    extra = []
    if r.frequencies_hz:
        extra.append(f"{_join(map(_num, r.frequencies_hz))} Hz")
    if _finite(r.share):
        extra.append(f"{100 * r.share:.0f} % of the structure")
    if _finite(r.rms_n):
        extra.append(f"{units.force(r.rms_n):.3g} {units.force_label} RMS")
    text = ", ".join(where)
    return text + (f" ({'; '.join(extra)})" if extra else "")


def _render_mismatch(page: Page, mismatch: Mismatch, units: Units) -> None:
    head = "significant" if mismatch.significant else "not significant"
    if not mismatch.tested:  # every test under two cycles: no noise to test by
        head = "not tested (no test has two whole cycles)"
    page.paragraph(
        f"Mismatch between model and measurement: {head} "
        f"(p = {_num(mismatch.p_value)}; noise floor "
        f"{_num(_times(mismatch.noise_floor_n, units.force_per_n))} "
        f"{units.force_label}; structured share "
        f"{_num(mismatch.structured_share)})."
    )
    if mismatch.where:
        page.table(
            ["stroke", "x range", "v range", "frequencies (Hz)", "share"],
            [
                [
                    w.stroke,
                    _range(w.x_range_m, units.length_per_m, units.length_label),
                    _range(w.v_range_m_s, *_speed(units)),
                    _join(map(_num, w.frequencies_hz)),
                    _num(w.share),
                ]
                for w in mismatch.where
            ],
            numeric=[False, False, False, False, True],
        )


def _render_findings(page: Page, findings: tuple[Finding, ...], units: Units) -> bool:
    if not findings:
        return False
    page.subheading("Findings: candidate physics")
    render_findings(page, findings, units)  # the terminal's and diagnose's page's cells
    return True


def _render_tests(page: Page, tests: tuple[ScoredTest, ...]) -> bool:
    if not tests:
        return False
    page.subheading("E_t per test, before and after the named physics")
    body = []
    for t in tests:
        b, a = t.E_t_before, t.E_t_after
        change = "–"
        if _finite(b) and _finite(a) and b > 0:
            change = f"{100 * (a - b) / b:+.1f} %"
        body.append(
            [
                str(t.index),
                str(t.clicks),
                _num(t.frequency_hz, "g"),
                _num(b, ".4g"),
                _num(a, ".4g"),
                change,
            ]
        )
    page.details(f"E_t of {len(tests)} tests", opened=len(tests) <= 12)
    page.table(
        ["test", "clicks", "f (Hz)", "E_t before", "E_t after", "change"],
        body,
        numeric=[True] * 6,
    )
    page.close_details()
    return True


def spec_shown(spec: SpecUsed) -> str:
    """The diagnosis's damper spec (``info.spec``) as a page shows it: never an absolute
    path of the machine that ran it. (A dict is read as DIAG.json would hold it.)"""
    text = f"{'built-in default ' if spec.default else ''}{shown_path(spec.path)} ({spec.name})"
    fit = spec.from_fit
    return f"{text}, the base spec of the fit {shown_path(fit)}" if fit else text


def render_diagnose(page: Page, doc: DiagnosisDoc, units: Units = SI) -> None:
    """Append the diagnose section for ``doc`` (a read DIAG.json), in ``units``."""
    page.section(
        "Diagnosis",
        "Where the fitted model and the measurement disagree, which extra physics explains "
        "it, and how much the error falls with it. E_t = ε_t / σ_F with ε_t² = ∫ (F_measured "
        "− F_model)² dt and σ_F² = ∫ (F_measured − mean F)² dt: the model's RMS force error "
        "as a share of the measured force's spread (0 is perfect).",
    )
    if doc.info.spec is not None:
        page.paragraph(f"Damper spec of the diagnosis: {spec_shown(doc.info.spec)}.")
    _render_verdict(page, doc.verdict, units)
    _render_mismatch(page, doc.mismatch, units)
    shown = [
        _render_findings(page, doc.findings, units),
        _render_tests(page, doc.tests),
    ]
    # An empty list is worded as absent, as pages have always said it.
    missing = [k for k, ok in zip(("findings", "tests"), shown, strict=True) if not ok]
    if missing:
        page.paragraph(f"Not in the diagnose file: {', '.join(missing)}.")


FIGURE_CAPTIONS = {
    "residual_maps": "Residual maps: the phase-locked residual (measured − model) against "
    "displacement and velocity, before (paper's model) and after (with the claimed physics).",
    "loops": "Residual loops: the tests with the most structure, measured against both models "
    "(F–v, F–v near reversal, F–x).",
}


def render_figures(
    page: Page,
    doc: DiagnosisDoc,
    base_dir: Path | None,
    link: Callable[[Path, int], str],
    units: Units = SI,
) -> None:
    """The residual maps and loops `diagnose --report` drew, named in ``info.figures``
    relative to ``base_dir`` (the JSON's folder); ``link`` copies one into the report's
    directory and returns its href, so the page links nothing outside it. Copied as drawn:
    a note when they were drawn in other units than the page's ``units``."""
    named = doc.info.figures
    if not named or base_dir is None:
        page.paragraph(
            "No residual maps or loops: this diagnosis was written without its figures "
            "(shockdyno diagnose ... --report DIR draws them, and DIAG.json then names them)."
        )
        return
    missing, shown = [], 0
    for n, (key, caption) in enumerate(FIGURE_CAPTIONS.items()):
        rel = named.get(key)
        if rel is None:
            continue
        png = base_dir / rel
        if png.suffix.lower() != ".png" or not png.is_file():
            missing.append(rel)
            continue
        page.figure(link(png, 50 + n), caption)
        shown += 1
    drawn = doc.info.figures_units or "si"  # batch diagnose draws in SI and does not say
    if shown and drawn != units.name:
        axes = "in, in/s, lbf" if drawn == "imperial" else "mm, m/s, N"
        page.paragraph(
            f"The residual maps and loops are drawn in {axes}, as diagnose --units {drawn} "
            "drew them; the rest of the page is converted."
        )
    if missing:
        page.paragraph(
            f"Figures of the diagnosis not found beside its JSON: {', '.join(missing)} "
            "(moved apart from DIAG.json?).",
            warn=True,
        )
