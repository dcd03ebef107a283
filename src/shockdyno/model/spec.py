"""Damper specification: geometry, oil, gas, valves, bleed laws. Loaded from TOML."""

from __future__ import annotations

import contextlib
import math
import tomllib
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shockdyno.errors import ConfigError
from shockdyno.model.bleed import BleedLaw
from shockdyno.model.shims import ShimStack


@dataclass(frozen=True)
class DamperSpec:
    name: str
    piston_diameter_m: float
    rod_diameter_m: float
    piston_rod_mass_kg: float
    oil_density_kg_m3: float
    oil_viscosity_cst: float
    discharge_coefficient: float
    gas_pressure_pa: float
    gas_piston_diameter_m: float
    gas_length_m: float
    gas_piston_mass_kg: float
    friction_n: float
    friction_velocity_m_s: float
    leak_gap_m: float
    leak_land_length_m: float
    bleed_bore_diameter_m: float
    compression_valve: ShimStack
    rebound_valve: ShimStack
    compression_bleed: BleedLaw
    rebound_bleed: BleedLaw
    max_gas_clicks: int = 0
    # Oil column above the piston: with the bore it gives the compression chamber's volume
    # (the compressibility term's V). Not in the paper; 80 mm for a 40 mm bore is typical.
    oil_column_m: float = 0.08

    # -- derived geometry -------------------------------------------------------------
    @property
    def piston_area_m2(self) -> float:
        return math.pi / 4 * self.piston_diameter_m**2

    @property
    def rod_area_m2(self) -> float:
        return math.pi / 4 * self.rod_diameter_m**2

    @property
    def annulus_area_m2(self) -> float:
        return self.piston_area_m2 - self.rod_area_m2

    @property
    def gas_piston_area_m2(self) -> float:
        return math.pi / 4 * self.gas_piston_diameter_m**2

    @property
    def bleed_bore_area_m2(self) -> float:
        """The bleed bore's cross-section: no bleed area can exceed it."""
        return math.pi / 4 * self.bleed_bore_diameter_m**2

    @property
    def viscosity_pa_s(self) -> float:
        return self.oil_viscosity_cst * 1e-6 * self.oil_density_kg_m3

    @property
    def leak_conductance_m3_s_pa(self) -> float:
        """Pressure-driven piston-wall leakage per pascal (eq. 4, first term)."""
        return (
            self.leak_gap_m**3
            / (12 * self.viscosity_pa_s * self.leak_land_length_m)
            * math.pi
            * self.piston_diameter_m
        )

    @property
    def couette_area_m2(self) -> float:
        """Flow dragged through the gap per unit rod velocity (eq. 4, second term)."""
        return self.leak_gap_m / 2 * math.pi * self.piston_diameter_m

    @property
    def max_travel_m(self) -> float:
        """Rod travel that would crush the gas chamber to zero volume (an absolute bound)."""
        return self.gas_piston_area_m2 * self.gas_length_m / self.rod_area_m2

    def bleed_areas(
        self, clicks: ArrayLike, gas_clicks: ArrayLike = 0
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """True (A_bc, A_bt) of this damper at the given rod and gas-bottle clicks."""
        n = np.asarray(clicks, dtype=float)
        g = np.asarray(gas_clicks, dtype=float)
        if np.any(n < 0) or np.any(n > self.compression_bleed.max_clicks):
            raise ConfigError(
                f"rod clicks must be 0-{self.compression_bleed.max_clicks}, got {n.tolist()}"
            )
        if np.any(g < 0) or np.any(g > self.max_gas_clicks):
            raise ConfigError(
                f"gas-bottle clicks must be 0-{self.max_gas_clicks}, got {g.tolist()}"
            )
        return self.compression_bleed.area(n, g), self.rebound_bleed.area(n, g)

    def with_changes(self, **changes: Any) -> DamperSpec:
        return replace(self, **changes)

    def validate(self) -> None:
        positive = [f.name for f in fields(self) if isinstance(getattr(self, f.name), float)]
        for name in positive:
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0:
                raise ConfigError(f"damper spec {self.name!r}: {name} must be >= 0, got {value}")
        if self.rod_diameter_m >= self.piston_diameter_m:
            raise ConfigError(f"damper spec {self.name!r}: rod must be thinner than the piston")
        bore = self.bleed_bore_area_m2
        for label, law in (
            ("compression", self.compression_bleed),
            ("rebound", self.rebound_bleed),
        ):
            if law.area_open_m2 > bore:
                raise ConfigError(
                    f"damper spec {self.name!r}: {label} bleed open area {law.area_open_m2:.3g} m² "
                    f"exceeds the {self.bleed_bore_diameter_m * 1e3:g} mm bore ({bore:.3g} m²)"
                )
            if law.shape_clicks <= 0:
                raise ConfigError(f"damper spec {self.name!r}: {label} shape_clicks must be > 0")


def default_spec_path() -> Path:
    """sim/ohlins-s46.toml of this checkout, else of the current directory."""
    here = Path(__file__).resolve().parents[3] / "sim" / "ohlins-s46.toml"
    return here if here.exists() else Path("sim/ohlins-s46.toml")


def spec_used(path: str | Path | None) -> dict[str, Any]:
    """Which spec a command used, for its terminal line and its JSON: {path, name,
    default}. `path` as the user gave it; the built-in default as its repository path."""
    p = default_spec_path() if path is None else Path(path)
    with contextlib.suppress(OSError):  # a fit's stored path to the default spec is the default
        default = path is None or p.resolve() == default_spec_path().resolve()
    shown = str(p)
    if default:
        root = Path(__file__).resolve().parents[3]
        with contextlib.suppress(ValueError):
            shown = str(p.resolve().relative_to(root))
    return {"path": shown, "name": load_spec(p).name, "default": default}


def spec_line(used: dict[str, Any]) -> str:
    """ "spec: sim/x.toml (name)", or "spec: built-in default sim/ohlins-s46.toml (...)"."""
    where = f"built-in default {used['path']}" if used.get("default") else used["path"]
    return f"spec: {where} ({used['name']})"


def _section(doc: dict[str, Any], key: str, path: Path) -> dict[str, Any]:
    value = doc.get(key)
    if not isinstance(value, dict):
        raise ConfigError(f"{path}: missing section [{key}]")
    return value


def _build(cls: type, data: dict[str, Any], where: str) -> Any:
    kinds = {f.name: str(f.type) for f in fields(cls)}
    unknown = sorted(set(data) - set(kinds))
    if unknown:
        raise ConfigError(f"{where}: unknown key {unknown[0]!r}")
    data = {k: _typed(v, kinds[k], f"{where} {k}") for k, v in data.items()}
    try:
        return cls(**data)
    except TypeError as exc:  # a required key is missing
        missing = str(exc).split("argument")[-1].strip(": ")
        raise ConfigError(f"{where}: missing {missing}") from None


def _typed(value: Any, kind: str, where: str) -> Any:
    """A TOML value checked against its field's type: a float field takes any number, an
    int field a whole number (``n_shims = 6.5`` is an error, not 6), a str field a string;
    a quoted number or a true/false is an error naming the key."""
    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{where}: a number, not {value!r}")
        return float(value)
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where}: a whole number, not {value!r}")
        return value
    if kind == "str" and not isinstance(value, str):
        raise ConfigError(f"{where}: a text in quotes, not {value!r}")
    return value


def load_spec(path: str | Path | None = None) -> DamperSpec:
    """Read a damper spec TOML; every problem is a one-line ConfigError."""
    p = Path(path) if path is not None else default_spec_path()
    try:
        doc = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise ConfigError(f"damper spec not found: {p}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML ({exc})") from None
    damper = dict(_section(doc, "damper", p))
    valves = _section(doc, "valves", p)
    bleed = _section(doc, "bleed", p)
    damper["compression_valve"] = _build(
        ShimStack, _section(valves, "compression", p), f"{p} [valves.compression]"
    )
    damper["rebound_valve"] = _build(
        ShimStack, _section(valves, "rebound", p), f"{p} [valves.rebound]"
    )
    damper["compression_bleed"] = _build(
        BleedLaw, _section(bleed, "compression", p), f"{p} [bleed.compression]"
    )
    damper["rebound_bleed"] = _build(
        BleedLaw, _section(bleed, "rebound", p), f"{p} [bleed.rebound]"
    )
    spec: DamperSpec = _build(DamperSpec, damper, f"{p} [damper]")
    spec.validate()
    return spec
