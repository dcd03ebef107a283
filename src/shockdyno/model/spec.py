"""Damper specification: geometry, oil, gas, valves, bleed laws. Loaded from TOML."""

from __future__ import annotations

import contextlib
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, Any, TypedDict

import numpy as np
from msgspec import Meta
from numpy.typing import ArrayLike, NDArray

from shockdyno.errors import ConfigError
from shockdyno.model.bleed import PATHS, Adjuster, BleedLaw
from shockdyno.model.shims import ShimStack
from shockdyno.schema import NonEmpty, NonNegative, Positive, Table, convert, fail, read_toml


@dataclass(frozen=True)
class DamperSpec:
    """A damper's spec file ([damper], [valves.*], [bleed.*]); read through shockdyno.schema,
    so the constraints on the fields' types are the file's."""

    name: NonEmpty
    piston_diameter_m: Positive
    rod_diameter_m: Positive
    piston_rod_mass_kg: NonNegative
    oil_density_kg_m3: Positive
    oil_viscosity_cst: Positive
    discharge_coefficient: Positive
    gas_pressure_pa: Positive
    gas_piston_diameter_m: Positive
    gas_length_m: Positive
    gas_piston_mass_kg: NonNegative
    friction_n: NonNegative
    friction_velocity_m_s: Positive
    leak_gap_m: NonNegative
    leak_land_length_m: Positive
    bleed_bore_diameter_m: Positive
    compression_valve: ShimStack
    rebound_valve: ShimStack
    compression_bleed: BleedLaw
    rebound_bleed: BleedLaw
    max_gas_clicks: Annotated[int, Meta(ge=0)] = 0
    # Oil column above the piston: with the bore it gives the compression chamber's volume
    # (the compressibility term's V). Not in the paper; 80 mm for a 40 mm bore is typical.
    oil_column_m: Positive = 0.08
    # Laminar length of the bleed passage (a needle's land, a drilled jet): Hagen-Poiseuille
    # in series with the sharp orifice, so viscosity (and the oil's temperature) acts on the
    # bleed's low-speed force. 0: the paper's sharp orifice, exactly. Calibrated by diagnose.
    bleed_land_m: NonNegative = 0.0
    # Radial width of the seat land the shim stacks lift off (both valves): the oil crosses
    # it as a plane Poiseuille flow in the gap the lift opens, in series with the opening's
    # orifice, so viscosity (and the oil's temperature) acts on the valve's force where it
    # opens. 0: the paper's sharp-edged opening, exactly. Calibrated by diagnose.
    valve_land_m: NonNegative = 0.0
    # How far the rod seal deflects at the Coulomb force before it slides (model/seal.py):
    # the friction turns over the travel since reversal. 0: the paper's smoothed sign
    # (friction_velocity_m_s), exactly. Calibrated by diagnose.
    friction_presliding_m: NonNegative = 0.0
    # The adjusters of a damper with several ([adjuster.NAME]): each acts on one bleed
    # path, whose law above is its own. Empty: the paper's one rod needle on both paths.
    adjusters: tuple[Adjuster, ...] = ()

    # -- derived geometry -------------------------------------------------------------
    @property
    def piston_area_m2(self) -> float:
        """The piston's full area (m²)."""
        return math.pi / 4 * self.piston_diameter_m**2

    @property
    def rod_area_m2(self) -> float:
        """The rod's cross-section (m²): what displaces oil into the gas column."""
        return math.pi / 4 * self.rod_diameter_m**2

    @property
    def annulus_area_m2(self) -> float:
        """Piston minus rod area (m²): the area Δp acts over (the Couette drag aside, the oil
        the piston displaces per m of travel)."""
        return self.piston_area_m2 - self.rod_area_m2

    @property
    def gas_piston_area_m2(self) -> float:
        """The gas (floating) piston's area (m²)."""
        return math.pi / 4 * self.gas_piston_diameter_m**2

    @property
    def gas_volume_m3(self) -> float:
        """The gas column's volume at the charge, the rod out (eq. 5's V0)."""
        return self.gas_piston_area_m2 * self.gas_length_m

    @property
    def bleed_bore_area_m2(self) -> float:
        """The bleed bore's cross-section: no bleed area can exceed it."""
        return math.pi / 4 * self.bleed_bore_diameter_m**2

    @property
    def viscosity_pa_s(self) -> float:
        """The oil's dynamic viscosity μ (Pa·s), from its kinematic viscosity (cSt) and density."""
        return self.oil_viscosity_cst * 1e-6 * self.oil_density_kg_m3

    @property
    def bleed_laminar_pa_s_m(self) -> float:
        """λ = 8π μ L of the bleed's land: its laminar resistance is λ / A² for a bleed of
        area A (Hagen-Poiseuille for a round passage of that area), so the laminar share
        of a bleed's drop at a given flow is the same at every click."""
        return 8 * math.pi * self.viscosity_pa_s * self.bleed_land_m

    @property
    def valve_laminar_pa_s(self) -> float:
        """λ_v = 12 μ L of the valves' seat land: the laminar resistance of an opening of
        perimeter P lifted y is λ_v / (P y³) (plane Poiseuille across the land)."""
        return 12 * self.viscosity_pa_s * self.valve_land_m

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
        return self.gas_volume_m3 / self.rod_area_m2

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

    @property
    def adjuster_names(self) -> tuple[str, ...]:
        """The names of the declared adjusters (empty: the paper's one rod needle)."""
        return tuple(a.name for a in self.adjusters)

    def adjuster_law(self, name: str) -> BleedLaw:
        """The area law of the named adjuster (its path's)."""
        for a in self.adjusters:
            if a.name == name:
                return self.compression_bleed if a.acts_on == "compression" else self.rebound_bleed
        known = ", ".join(self.adjuster_names) or "none: one rod adjuster"
        raise ConfigError(f"the damper {self.name} has no adjuster {name!r} (it has {known})")

    def adjuster_on(self, path: str) -> str:
        """The name of the adjuster acting on a bleed path ("" with the one rod needle)."""
        return next((a.name for a in self.adjusters if a.acts_on == path), "")

    def setting_areas(
        self, setting: Mapping[str, int], gas_clicks: ArrayLike = 0
    ) -> tuple[float, float]:
        """True (A_bc, A_bt) at one setting of every declared adjuster (a ConfigError for
        a missing, unknown or out-of-range one)."""
        if set(setting) != set(self.adjuster_names):
            raise ConfigError(
                f"the damper {self.name} has adjusters {', '.join(self.adjuster_names)}; "
                f"got a setting of {', '.join(setting) or 'none'}"
            )
        g = np.asarray(gas_clicks, dtype=float)
        if np.any(g < 0) or np.any(g > self.max_gas_clicks):
            raise ConfigError(
                f"gas-bottle clicks must be 0-{self.max_gas_clicks}, got {g.tolist()}"
            )
        areas = {}
        for a in self.adjusters:
            law, n = self.adjuster_law(a.name), setting[a.name]
            if not 0 <= n <= law.max_clicks:
                raise ConfigError(f"{a.name} clicks must be 0-{law.max_clicks}, got {n}")
            areas[a.acts_on] = float(law.area(n, g))
        return areas["compression"], areas["rebound"]

    # Any: dataclasses.replace checks each field against its own type (floats, valves, ...)
    def with_changes(self, **changes: Any) -> DamperSpec:
        """A copy with these fields replaced (dataclasses.replace; not checked again)."""
        return replace(self, **changes)

    # A spec value by name: a field ("friction_n") or a valve's field
    # ("rebound_valve.preload_m"). The only place such a name is resolved.
    def value(self, key: str) -> float:
        """A number of the spec by name: a field (`friction_n`) or a valve's field
        (`rebound_valve.preload_m`), in SI; ConfigError for any other name."""
        head, _, tail = key.partition(".")
        part = getattr(self, head, None) if not head.startswith("_") else None
        if part is not None and tail:
            part = getattr(part, tail, None) if not tail.startswith("_") else None
        if isinstance(part, bool) or not isinstance(part, int | float):
            raise ConfigError(f"unknown damper parameter {key!r}")
        return float(part)

    def with_values(self, values: Mapping[str, float]) -> DamperSpec:
        """A copy with these named values (as `value` names them) replaced."""
        changes: dict[str, Any] = {}  # Any: fields of several types, for replace
        parts: dict[str, dict[str, float]] = {}  # a valve's fields, replaced in one copy
        for key, v in values.items():
            self.value(key)  # a name that is not a number of the spec is an error
            head, _, tail = key.partition(".")
            if tail:
                parts.setdefault(head, {})[tail] = float(v)
            else:
                changes[head] = float(v)
        for head, fields in parts.items():
            changes[head] = replace(getattr(self, head), **fields)
        return replace(self, **changes)

    def validate(self) -> None:
        """What one field's type cannot say (the types are checked as the file is read);
        a ConfigError naming the key."""
        if self.rod_diameter_m >= self.piston_diameter_m:
            raise ConfigError(
                f"damper.rod_diameter_m: {self.rod_diameter_m * 1e3:g} mm must be thinner "
                f"than the {self.piston_diameter_m * 1e3:g} mm piston (the rod must be thinner)"
            )
        bore = self.bleed_bore_area_m2
        for label, law in (
            ("compression", self.compression_bleed),
            ("rebound", self.rebound_bleed),
        ):
            if law.area_open_m2 > bore:
                raise ConfigError(
                    f"bleed.{label}.area_open_m2: {law.area_open_m2:.3g} m² exceeds the "
                    f"{self.bleed_bore_diameter_m * 1e3:g} mm bore ({bore:.3g} m²)"
                )
        for label, v in (("compression", self.compression_valve), ("rebound", self.rebound_valve)):
            if not v.clamp_diameter_m < v.outer_diameter_m:
                raise ConfigError(
                    f"valves.{label}.clamp_diameter_m: {v.clamp_diameter_m * 1e3:g} mm must be "
                    f"less than outer_diameter_m ({v.outer_diameter_m * 1e3:g} mm)"
                )
            if not v.clamp_diameter_m <= v.seat_diameter_m <= v.outer_diameter_m:
                raise ConfigError(
                    f"valves.{label}.seat_diameter_m: {v.seat_diameter_m * 1e3:g} mm must lie "
                    f"between clamp_diameter_m and outer_diameter_m"
                )


def default_spec_path() -> Path:
    """sim/ohlins-s46.toml of this checkout, else of the current directory."""
    here = Path(__file__).resolve().parents[3] / "sim" / "ohlins-s46.toml"
    return here if here.exists() else Path("sim/ohlins-s46.toml")


class SpecInfo(TypedDict):
    """Which damper spec a command used, as its JSON records it: the path as the user gave it
    (the built-in default's repository path), the spec's name, and whether it is the built-in
    default."""

    path: str
    name: str
    default: bool


def spec_used(path: str | Path | None) -> SpecInfo:
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


def spec_line(used: Mapping[str, object]) -> str:
    """ "spec: sim/x.toml (name)", or "spec: built-in default sim/ohlins-s46.toml (...)"."""
    where = f"built-in default {used['path']}" if used.get("default") else used["path"]
    return f"spec: {where} ({used['name']})"


@dataclass(frozen=True)
class _Valves:
    compression: ShimStack
    rebound: ShimStack


@dataclass(frozen=True)
class _Bleeds:
    compression: BleedLaw
    rebound: BleedLaw


@dataclass(frozen=True)
class _SpecFile:
    damper: Table  # DamperSpec's own keys, checked with the valves and bleeds in
    valves: _Valves
    bleed: _Bleeds | None = None
    # [adjuster.NAME]: acts_on and its area law's keys (BleedLaw's), checked below
    adjuster: dict[str, Table] | None = None


ADJUSTER_NAME = re.compile(r"^[a-z][a-z0-9_]{0,31}$")
RESERVED_ADJUSTERS = ("gas", "rod", "clicks")  # the gas bottle's and the one needle's words


def _adjusters(p: Path, tables: dict[str, Table]) -> tuple[tuple[Adjuster, ...], Table]:
    """[adjuster.NAME] tables: the adjusters and each path's law from its adjuster's table."""
    found: list[Adjuster] = []
    laws: Table = {}
    for name, table in tables.items():
        at = f"adjuster.{name}"
        if not ADJUSTER_NAME.match(name) or name in RESERVED_ADJUSTERS:
            raise fail(
                str(p),
                at,
                "an adjuster's name is lower-case letters, digits and _ (not "
                + ", ".join(RESERVED_ADJUSTERS)
                + ")",
            )
        if not isinstance(table, dict):
            raise fail(str(p), at, "must be a table")
        acts_on = table.get("acts_on")
        if acts_on not in PATHS:
            raise fail(
                str(p), f"{at}.acts_on", f"must be one of {', '.join(PATHS)}, got {acts_on!r}"
            )
        if f"{acts_on}_bleed" in laws:
            raise fail(str(p), f"{at}.acts_on", f"another adjuster already acts on {acts_on}")
        law = {k: v for k, v in table.items() if k != "acts_on"}
        convert(law, BleedLaw, str(p), at)  # its errors name the adjuster's table
        laws[f"{acts_on}_bleed"] = law
        found.append(Adjuster(name, acts_on))
    for path in PATHS:
        if f"{path}_bleed" not in laws:
            raise fail(str(p), "adjuster", f"no adjuster acts on the {path} bleed")
    return tuple(found), laws


PARTS = ("compression_valve", "rebound_valve", "compression_bleed", "rebound_bleed")


def load_spec(path: str | Path | None = None) -> DamperSpec:
    """Read a damper spec TOML; every problem is a one-line ConfigError."""
    p = Path(path) if path is not None else default_spec_path()
    _, doc = read_toml(p, f"damper spec not found: {p}")
    f = convert(doc, _SpecFile, str(p))
    for key in PARTS:
        if key in f.damper:
            raise fail(str(p), f"damper.{key}", "unknown key (it has its own table)")
    if "adjusters" in f.damper:
        raise fail(str(p), "damper.adjusters", "unknown key (each has its [adjuster.NAME])")
    parts: Table = {
        "compression_valve": doc["valves"]["compression"],
        "rebound_valve": doc["valves"]["rebound"],
    }
    adjusters: tuple[Adjuster, ...] = ()
    if f.adjuster:
        if f.bleed is not None:
            raise fail(
                str(p), "bleed", "the [adjuster.*] tables carry the bleed laws: drop [bleed]"
            )
        adjusters, laws = _adjusters(p, doc["adjuster"])
    elif f.bleed is None:
        raise fail(
            str(p), "bleed", "missing: [bleed.compression] and [bleed.rebound], or [adjuster.*]"
        )
    else:
        laws = {
            "compression_bleed": doc["bleed"]["compression"],
            "rebound_bleed": doc["bleed"]["rebound"],
        }
    spec = convert({**f.damper, **parts, **laws}, DamperSpec, str(p), "damper")
    spec = replace(spec, adjusters=adjusters)
    try:
        spec.validate()
    except ConfigError as exc:
        raise ConfigError(f"{p}: {exc}") from None
    return spec
