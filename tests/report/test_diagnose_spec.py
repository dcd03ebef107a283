"""The diagnosis's damper spec on a page: named, never as this machine's absolute path."""

from __future__ import annotations

from pathlib import Path

from shockdyno.report.diagnose_section import render_diagnose
from shockdyno.report.html import Page


def test_the_spec_is_shown_without_this_machines_path(tmp_path: Path) -> None:
    spec = {"path": "/home/jd/dampers/specs/mine.toml", "name": "my-46mm", "default": False}
    spec["from_fit"] = "/home/jd/fits/FIT.json"
    page = Page("t")
    render_diagnose(page, {"info": {"spec": spec}})
    text = page.render()
    assert "specs/mine.toml (my-46mm)" in text and "fits/FIT.json" in text
    assert "/home/jd" not in text
