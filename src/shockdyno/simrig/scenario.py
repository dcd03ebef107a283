"""Scenario files (`sim/scenarios/*.toml`): extra physics and sensor effects for the sim-rig.

[scenario]
name = "aerated-oil"
description = "..."
[[term]]
kind = "compressibility"      # a term of the library (shockdyno.model.terms.LIBRARY)
air_fraction = 0.03           # its parameters by local name (SI); others stay nominal
[sensors]
lvdt_lag_s = 0.001            # optional LVDT first-order lag

or, instead of terms, the reference plant (simrig/reference.py: physics written apart
from the term library) with any of its parameters:
[plant]
kind = "reference"
air_fraction = 0.02
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from shockdyno.errors import ConfigError
from shockdyno.model.composite import Term
from shockdyno.model.terms import make_term
from shockdyno.schema import NonEmpty, NonNegative, convert, dotted, fail, read_toml, shown
from shockdyno.simrig.reference import PlantParams


@dataclass
class Scenario:
    """A simulation scenario (sim/scenarios/*.toml): the physics terms switched on in the
    simulated damper and their values (qualified names), the LVDT's lag (s), or the reference
    plant instead of the library's model."""

    name: str
    description: str = ""
    terms: list[Term] = field(default_factory=list)
    values: dict[str, float] = field(default_factory=dict)  # qualified parameter values
    lvdt_lag_s: float = 0.0
    source: str = ""
    plant: PlantParams | None = None  # the reference plant instead of the paper's model


def scenario_dir() -> Path:
    """The folder of the shipped scenarios (the repository's sim/scenarios, else relative to the
    working directory)."""
    here = Path(__file__).resolve().parents[3] / "sim" / "scenarios"
    return here if here.exists() else Path("sim/scenarios")


@dataclass(frozen=True)
class _Head:
    name: NonEmpty
    description: str = ""


@dataclass(frozen=True)
class _Sensors:
    lvdt_lag_s: NonNegative = 0.0


@dataclass(frozen=True)
class _ScenarioFile:
    scenario: _Head
    # Each term's keys are its own parameters (Param: name, bounds), checked below.
    term: list[dict[str, Any]] = field(default_factory=list)
    sensors: _Sensors = field(default_factory=_Sensors)
    plant: dict[str, Any] | None = None  # PlantParams, checked on its own


def _term(t: dict[str, Any], src: str, at: str, values: dict[str, float]) -> Term:  # TOML
    """A [[term]] table: `kind` and the term's own parameters within their bounds."""
    if "kind" not in t:
        raise fail(src, f"{at}.kind", "missing")
    if not isinstance(t["kind"], str):
        raise fail(src, f"{at}.kind", f"must be a term's name in quotes, got {shown(t['kind'])}")
    try:
        term = make_term(t["kind"])
    except ConfigError as exc:
        raise fail(src, f"{at}.kind", str(exc)) from None
    declared = {q.name: q for q in term.params()}
    for key, value in t.items():
        if key == "kind":
            continue
        if key not in declared:
            near = difflib.get_close_matches(key, declared, n=1)
            hint = f" (did you mean {near[0]}?)" if near else f" for {term.name}"
            raise fail(src, f"{at}.{key}", f"unknown key{hint}")
        q = declared[key]
        number = not isinstance(value, bool) and isinstance(value, int | float)
        if not (number and math.isfinite(value) and q.lo <= value <= q.hi):
            got = shown(value)
            raise fail(src, f"{at}.{key}", f"must be a number from {q.lo:g} to {q.hi:g}, got {got}")
        values[term.qualified(key)] = float(value)
    return term


def load_scenario(path: str | Path) -> Scenario:
    """A scenario by path, or by name from sim/scenarios/."""
    p = Path(path)
    if not p.exists() and p.suffix != ".toml":
        p = scenario_dir() / f"{path}.toml"
    _, doc = read_toml(p, f"scenario not found: {path}")
    src = str(p)
    f = convert(doc, _ScenarioFile, src)
    values: dict[str, float] = {}
    terms = [_term(t, src, f"term[{i}]", values) for i, t in enumerate(f.term)]
    names = [t.name for t in terms]
    for i, name in enumerate(names):
        if name in names[:i]:
            raise fail(src, f"term[{i}].kind", f"{name} is already term[{names.index(name)}]")
    plant = None
    if f.plant is not None:
        kind = f.plant.get("kind")
        if kind is None:
            raise fail(src, "plant.kind", 'missing ("reference", or "paper" for the model)')
        if kind not in ("paper", "reference"):
            raise fail(src, "plant.kind", f'must be "paper" or "reference", got {shown(kind)}')
        extra = sorted(k for k in f.plant if k != "kind")
        if kind == "paper" and extra:
            raise fail(src, dotted("plant", extra[0]), 'only with kind = "reference"')
        if kind == "reference":
            if terms:
                raise fail(src, "plant", "the reference plant takes its own parameters, not terms")
            plant = PlantParams.from_table(f.plant, src)
    return Scenario(
        name=f.scenario.name,
        description=f.scenario.description,
        terms=terms,
        values=values,
        lvdt_lag_s=f.sensors.lvdt_lag_s,
        source=src,
        plant=plant,
    )
