"""The diagnosis's damper spec on a page: named, never as this machine's absolute path."""

from __future__ import annotations

from doc_samples import diagnosis

from shockdyno.report.diagnose_section import render_diagnose, spec_shown
from shockdyno.report.documents import SpecUsed, typed
from shockdyno.report.html import Page


def test_the_spec_is_shown_without_this_machines_path() -> None:
    spec = {"path": "/home/jd/dampers/specs/mine.toml", "name": "my-46mm", "default": False}
    spec["from_fit"] = "/home/jd/fits/FIT.json"
    page = Page("t")
    render_diagnose(page, diagnosis(info={"spec": spec}))
    text = page.render()
    assert "specs/mine.toml (my-46mm)" in text and "fits/FIT.json" in text
    assert "/home/jd" not in text


def test_spec_shown_reads_the_dict_diagnose_writes_as_its_file() -> None:
    # A spec as DIAG.json holds it (`info.spec`), read as the typed document.
    used = {"path": "sim/ohlins-s46.toml", "name": "ohlins-s46", "default": True}
    spec = typed(used, SpecUsed, "info.spec")
    assert spec == SpecUsed(path="sim/ohlins-s46.toml", name="ohlins-s46", default=True)
    assert spec_shown(spec) == "built-in default sim/ohlins-s46.toml (ohlins-s46)"
