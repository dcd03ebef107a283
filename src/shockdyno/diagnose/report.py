"""`diagnose --report DIR`: the figures and a page that states the verdict."""

from __future__ import annotations

import os
from pathlib import Path

from shockdyno.atomic import write_text_atomic
from shockdyno.diagnose.diagnosis import Diagnosis
from shockdyno.diagnose.plots import loops, residual_maps
from shockdyno.report.diagnose_section import spec_shown
from shockdyno.report.documents import DiagnosisDoc
from shockdyno.report.findings_table import render_findings
from shockdyno.report.html import Page
from shockdyno.report.unexplained_section import render_unexplained
from shockdyno.units import SI, Units

# The figures' names in DIR and their keys in DIAG.json's info.figures.
FIGURES = {"residual_maps": "diagnose-residual-maps.png", "loops": "diagnose-loops.png"}


def figure_paths(report_dir: Path, json_path: str) -> dict[str, str]:
    """info.figures of DIAG.json: each figure of `write_report` relative to the JSON's
    folder (to the working directory for '-'), so `report --diagnose DIAG.json` finds
    them, also after the two are moved together."""
    base = Path(json_path).parent if json_path != "-" else Path.cwd()
    return {
        key: Path(os.path.relpath(report_dir / name, base)).as_posix()
        for key, name in FIGURES.items()
    }


def write_report(d: Diagnosis, doc: DiagnosisDoc, out: Path, units: Units = SI) -> Path:
    """The page and its figures, forces, lengths and speeds in ``units``."""
    out.mkdir(parents=True, exist_ok=True)
    maps = residual_maps(d, out / FIGURES["residual_maps"], units)
    lp = loops(d, out / FIGURES["loops"], units)
    page = Page("Diagnosis: where the model and the recording differ, and why")
    page.section("Verdict")
    v = doc.verdict
    page.paragraph((v.text_imperial if units.imperial else None) or v.text)
    # what is left, described, with its discovered term and figure (issue 45)
    render_unexplained(page, v.unexplained, units)
    if doc.info.spec is not None:
        page.paragraph(f"Damper spec: {spec_shown(doc.info.spec)}.")
    page.section(
        "Findings",
        "Each candidate term refitted with the globals and areas; p from a cycle-bootstrap "
        "likelihood ratio, held-out gain the share of held-out structure it removes (median "
        "fold).",
    )
    render_findings(page, doc.findings, units)
    page.section("Residual maps", "Phase-locked residual against displacement and velocity.")
    page.figure(maps.name, "Residual before (paper's model) and after (with the claimed physics)")
    page.section("Loops", "The tests with the most structure, measured against both models.")
    page.figure(lp.name, "Measured loops with the paper's model and the augmented model")
    page.section("Per test")
    page.table(
        ["test", "clicks", "Hz", "E_t before", "E_t after"],
        [
            [
                str(t.index),
                str(t.clicks),
                f"{t.frequency_hz:g}",
                f"{t.E_t_before:.4g}" if t.E_t_before is not None else "–",
                f"{t.E_t_after:.4g}" if t.E_t_after is not None else "–",
            ]
            for t in doc.tests
        ],
        numeric=[True, True, True, True, True],
    )
    index = out / "index.html"
    write_text_atomic(index, page.render())
    return index
