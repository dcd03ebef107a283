"""The report in a real browser: every image loads, no script errors, no sideways scroll
at 800 px. Skipped without Chromium (README: `apt-get install chromium`)."""

from __future__ import annotations

from pathlib import Path

import pytest
from browser import find_chromium, open_page

CHROMIUM = find_chromium()
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no chromium: apt-get install chromium")


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
