"""The report in a real browser: every image loads, no script errors, no sideways scroll
at 800 px. Skipped without Chromium (tests/report/browser.py says how to enable them)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from browser import find_chromium, open_page

from shockdyno.report.html import PRINT_CSS, PRINT_SCRIPT

CHROMIUM = find_chromium()
pytestmark = pytest.mark.browser  # skipped without Chromium (tests/conftest.py)


def test_the_probe_sees_a_broken_image_and_a_script_error(tmp_path: Path) -> None:
    # The harness itself: a page with a missing image and a throwing script is caught.
    (tmp_path / "index.html").write_text(
        '<html><body><img src="missing.png"><script>throw new Error("boom")</script></body></html>'
    )
    assert CHROMIUM is not None
    seen = open_page(CHROMIUM, tmp_path / "index.html")
    assert [i["ok"] for i in seen.images] == [False]
    assert any("boom" in e for e in seen.errors)


@pytest.mark.parametrize("width", [800, 1280])
def test_every_image_loads_and_no_errors(full_report: Path, width: int) -> None:
    assert CHROMIUM is not None
    seen = open_page(CHROMIUM, full_report, width=width)
    assert len(seen.images) >= 8  # click chart, peaks, overlays, fit, loops
    assert [i["src"] for i in seen.images if not i["ok"]] == []
    assert seen.errors == [] and seen.failed_loads == []
    # Wide tables scroll inside their own box; the page itself fits the window.
    assert seen.scroll_width_px <= width


def _pdf_images(pdf: bytes) -> int:
    return len(re.findall(rb"/Subtype\s*/Image\b", pdf))


def test_print_to_pdf_is_the_whole_report(full_report: Path, tmp_path: Path) -> None:
    """Printed as a reader would (open, wait for the images, print): every collapsed
    block is open and every figure in the PDF; no navigation; figures and tables are
    not split. The same page without its print stylesheet and script prints only the
    figures that happened to be on screen."""
    assert CHROMIUM is not None
    figures = set(re.findall(r'<img src="([^"]+)"', full_report.read_text()))
    assert len(figures) >= 8 and "<details>" in full_report.read_text()  # some start closed
    printed = open_page(CHROMIUM, full_report, print_pdf=True)
    assert printed.pdf.startswith(b"%PDF")
    assert _pdf_images(printed.pdf) == len(figures)
    assert printed.print_styles == {"nav": "none", "figure": "avoid", "table": "avoid"}

    bare = tmp_path / "bare"
    shutil.copytree(full_report.parent, bare)
    html = full_report.read_text().replace(PRINT_CSS, "").replace(PRINT_SCRIPT, "")
    (bare / "index.html").write_text(html)
    without = open_page(CHROMIUM, bare / "index.html", print_pdf=True)
    assert _pdf_images(without.pdf) < len(figures)
    assert without.print_styles["nav"] != "none"
