"""Scenario files (`sim/scenarios/*.toml`): extra physics and sensor effects for the sim-rig.

[scenario]
name = "aerated-oil"
description = "..."
[[term]]
kind = "compressibility"      # a key of shockdyno.model.extras.TERM_KINDS
air_fraction = 0.03           # the term's parameters (SI)
[sensors]
lvdt_lag_s = 0.001            # optional LVDT first-order lag
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from shockdyno.errors import ConfigError
from shockdyno.model.extras import make_term


@dataclass
class Scenario:
    name: str
    description: str = ""
    terms: list[Any] = field(default_factory=list)
    lvdt_lag_s: float = 0.0
    source: str = ""


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
    unknown = sorted(set(doc) - {"scenario", "term", "sensors"})
    if unknown:
        raise ConfigError(f"{p}: {unknown[0]}: unknown key")
    terms = []
    for i, t in enumerate(doc.get("term", [])):
        if not isinstance(t, dict) or "kind" not in t:
            raise ConfigError(f"{p}: term[{i}].kind: missing")
        params = {k: v for k, v in t.items() if k != "kind"}
        terms.append(make_term(str(t["kind"]), params, f"{p}: term[{i}]"))
    sensors = doc.get("sensors", {})
    lag = sensors.get("lvdt_lag_s", 0.0) if isinstance(sensors, dict) else None
    if isinstance(lag, bool) or not isinstance(lag, int | float) or lag < 0:
        raise ConfigError(f"{p}: sensors.lvdt_lag_s: must be a number >= 0")
    return Scenario(
        name=head["name"],
        description=str(head.get("description", "")),
        terms=terms,
        lvdt_lag_s=float(lag),
        source=str(p),
    )
