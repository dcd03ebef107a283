"""What the concealed-effect modules on plants written apart from the library share
(test_diagnose_reference.py, test_diagnose_holdout.py): each case made and diagnosed
when a test first asks for it, so each test pays (and is timed for) its own."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np


class Made(dict):  # type: ignore[type-arg]
    """name -> make(name), made when first asked for."""

    def __init__(self, make: Callable[[str], Any]) -> None:
        super().__init__()
        self.make = make

    def __missing__(self, name: str) -> Any:
        self[name] = self.make(name)
        return self[name]


def claimed_values(d: dict[str, Any], physics: str) -> dict[str, float]:
    """The claimed term's parameters, by name, in DIAG.json."""
    (f,) = [f for f in d["findings"] if f["physics"] == physics and f["claimed"]]
    return {k: p["value"] for k, p in f["parameters"].items()}


def assert_modelled(d: dict[str, Any], clean: dict[str, Any], times: float = 1.5) -> None:
    """Modelled to near the clean sweep's own level (within 1.5x its E_t after), and
    better than without it. (Half its E_t before, the older bar, asks a faint effect to
    stand well above the clean plant's own misfit: the reference plant's clean sweep is
    left at E_t 0.012, its 40 N seal starts at 0.020.)"""
    before = np.mean([t["E_t_before"] for t in d["tests"]])
    after = np.mean([t["E_t_after"] for t in d["tests"]])
    floor = np.mean([t["E_t_after"] for t in clean["tests"]])
    assert after < before and after <= times * floor, (before, after, floor, d["verdict"]["text"])
