"""Unexplained regions read as words on the page, not as Python dicts (issue 21.8)."""

from __future__ import annotations

from pathlib import Path

from doc_samples import REGION, diag

from shockdyno.report.build import build_report
from shockdyno.report.diagnose_section import region_text
from shockdyno.report.documents import Region, typed


def test_unexplained_regions_are_words(tmp_path: Path) -> None:
    region = REGION
    # As a dict, as `diagnose` writes it: build_report reads it as its file would be.
    doc = diag(verdict={"physics": [], "unexplained": [region], "text": "Mismatch."})
    index = build_report([], tmp_path / "r", title="t", diagnose=doc)
    html = index.read_text()
    assert "in rebound at 15.6 to 29.2 mm, -0.097 to -0.036 m/s, near reversal" in html
    assert "25 % of the structure" in html and "19 N RMS" in html
    assert "{&#x27;stroke" not in html and "{'stroke" not in html and "x_range_m" not in html
    assert region_text(typed(region, Region, "region")) in html
