"""Plots and the HTML report.

`build_report` and the summary are loaded when first used: a command that reads only
the report's options or its documents (`shockdyno --help`, `report`'s argument checks)
does not pay for matplotlib."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from shockdyno.report.build import build_report
    from shockdyno.report.summary import TestSummary, summarise

__all__ = ["TestSummary", "build_report", "summarise"]
_WHERE = {
    "build_report": "shockdyno.report.build",
    "TestSummary": "shockdyno.report.summary",
    "summarise": "shockdyno.report.summary",
}


def __getattr__(name: str) -> object:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_WHERE[name]), name)
