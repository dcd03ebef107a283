"""Plots and the HTML report."""

from shockdyno.report.build import build_report
from shockdyno.report.summary import TestSummary, summarise

__all__ = ["TestSummary", "build_report", "summarise"]
