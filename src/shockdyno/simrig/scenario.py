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

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from shockdyno.errors import ConfigError
from shockdyno.model.composite import Term
from shockdyno.model.terms import make_term
from shockdyno.simrig.reference import PlantParams


@dataclass
class Scenario:
    name: str
    description: str = ""
    terms: list[Term] = field(default_factory=list)
    values: dict[str, float] = field(default_factory=dict)  # qualified parameter values
    lvdt_lag_s: float = 0.0
    source: str = ""
    plant: PlantParams | None = None  # the reference plant instead of the paper's model


def scenario_dir() -> Path:
    here = Path(__file__).resolve().parents[3] / "sim" / "scenarios"
    return here if here.exists() else Path("sim/scenarios")


def load_scenario(path: str | Path) -> Scenario:
    """A scenario by path, or by name from sim/scenarios/."""
    p = Path(path)
    if not p.exists() and p.suffix != ".toml":
        p = scenario_dir() / f"{path}.toml"
    try:
        doc = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise ConfigError(f"scenario not found: {path}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML ({exc})") from None
    head = doc.get("scenario")
    if not isinstance(head, dict) or not isinstance(head.get("name"), str):
        raise ConfigError(f"{p}: scenario.name: missing")
    unknown = sorted(set(doc) - {"scenario", "term", "sensors", "plant"})
    if unknown:
        raise ConfigError(f"{p}: {unknown[0]}: unknown key")
    terms: list[Term] = []
    values: dict[str, float] = {}
    for i, t in enumerate(doc.get("term", [])):
        where = f"{p}: term[{i}]"
        if not isinstance(t, dict) or "kind" not in t:
            raise ConfigError(f"{where}.kind: missing")
        try:
            term = make_term(str(t["kind"]))
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        declared = {q.name: q for q in term.params()}
        for key, value in t.items():
            if key == "kind":
                continue
            if key not in declared:
                raise ConfigError(f"{where}: unknown key {key!r} for {term.name}")
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ConfigError(f"{where}: {key} must be a number, got {value!r}")
            q = declared[key]
            if not (math.isfinite(value) and q.lo <= value <= q.hi):
                raise ConfigError(f"{where}: {key} must be in [{q.lo:g}, {q.hi:g}], got {value!r}")
            values[term.qualified(key)] = float(value)
        terms.append(term)
    plant = None
    table = doc.get("plant")
    if table is not None:
        if not isinstance(table, dict) or table.get("kind", "paper") not in ("paper", "reference"):
            raise ConfigError(f'{p}: plant.kind: "paper" or "reference"')
        if table.get("kind") == "reference":
            if terms:
                raise ConfigError(f"{p}: the reference plant takes its own parameters, not terms")
            plant = PlantParams.from_table(table, f"{p}: plant")
    sensors = doc.get("sensors", {})
    lag = sensors.get("lvdt_lag_s", 0.0) if isinstance(sensors, dict) else None
    if isinstance(lag, bool) or not isinstance(lag, int | float) or lag < 0:
        raise ConfigError(f"{p}: sensors.lvdt_lag_s: must be a number >= 0")
    return Scenario(
        name=head["name"],
        description=str(head.get("description", "")),
        terms=terms,
        values=values,
        lvdt_lag_s=float(lag),
        source=str(p),
        plant=plant,
    )
