"""The least a DIAG.json and a RIDE.json hold, for tests that vary one part of them."""

from __future__ import annotations

import copy
from typing import Any

from shockdyno.report.documents import DiagnosisDoc, RideDoc, typed

# The keys every writer has written (report/documents.py), with nothing to show in them.
MINIMAL_DIAG: dict[str, Any] = {
    "mismatch": {"significant": False, "p_value": 0.5, "noise_floor_n": 2.0,
                 "structured_share": 0.1, "where": []},
    "findings": [],
    "verdict": {"text": "No mismatch beyond noise.", "physics": [], "unexplained": []},
    "tests": [],
}  # fmt: skip

MINIMAL_RIDE: dict[str, Any] = {
    "rms": [],
    "flags": {"travel_m": 0.05},
    "quarter_car": {"sprung_mass_kg": 500.0, "unsprung_mass_kg": 60.0, "spring_n_m": 60000.0,
                    "tyre_n_m": 220000.0},
    "damper": {"kind": "linear", "c_ns_m": 3000.0},
}  # fmt: skip


# A located region as diagnose writes it (mismatch.where[], verdict.unexplained[]).
REGION = {
    "stroke": "rebound",
    "x_range_m": [0.0156, 0.0292],
    "v_range_m_s": [-0.097, -0.036],
    "frequencies_hz": [1.0, 1.5],
    "share": 0.25,
    "rms_n": 19.0,
    "near_reversal": True,
}


def diag(**parts: Any) -> dict[str, Any]:
    """MINIMAL_DIAG with these top-level parts replaced, as a parsed DIAG.json."""
    return copy.deepcopy(MINIMAL_DIAG) | parts


def diagnosis(**parts: Any) -> DiagnosisDoc:
    return typed(diag(**parts), DiagnosisDoc, "sample DIAG.json")


def ride(**parts: Any) -> RideDoc:
    return typed(copy.deepcopy(MINIMAL_RIDE) | parts, RideDoc, "sample RIDE.json")
