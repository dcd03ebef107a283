"""A fitted term's parameters as a person reads them: the values, their σ, which ones the
data moved, in display units. A term's `describe` words its own physics from one."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from shockdyno.model.params import Estimate, Param
from shockdyno.units import SI, Units


@dataclass(frozen=True)
class Reading:
    """`values`: the term's fitted parameters by name (a finding's)."""

    params: tuple[Param, ...]
    values: Mapping[str, Estimate]
    units: Units = SI
    spec_gas_pa: float = math.nan  # the spec's gas charge: the pressure air is counted at
    # The stroke the data cover (x min, max): a place outside it is nothing the data showed.
    reach_m: tuple[float, float] = (-math.inf, math.inf)

    def reached(self, x_m: float) -> bool:
        """Whether the data reach position `x_m` (a NaN is nowhere)."""
        return self.reach_m[0] <= x_m <= self.reach_m[1]

    def v(self, name: str) -> float:
        """A parameter's fitted value in SI (NaN when missing or not finite)."""
        est = self.values.get(name)  # a non-finite value (an off value) reads as NaN, as in JSON
        return est.value if est is not None and math.isfinite(est.value) else math.nan

    def sd_value(self, name: str) -> float:
        """σ of a parameter (NaN when the fit gave none)."""
        est = self.values.get(name)
        return est.sd if est is not None and math.isfinite(est.sd) else math.nan

    def sd(self, name: str, scale: float = 1.0) -> str:
        """ " ± σ" in the value's scale, or "" when the fit gave none."""
        sd = self.sd_value(name)
        return f" ± {scale * sd:.2g}" if math.isfinite(sd) else ""

    def moved(self, name: str) -> bool:
        """Whether a parameter moved off its off value by more than 3σ (and than a rounding
        of its scale): a term's text names only what the data moved."""
        param = next((p for p in self.params if p.name == name), None)
        value = self.v(name)
        est = self.values.get(name)
        if param is None or not math.isfinite(value) or (est is not None and est.fixed):
            return False
        sd = self.sd_value(name)
        noise = 3 * sd if math.isfinite(sd) else 0.0
        return abs(value - param.off) > max(noise, 1e-3 * param.scale)

    # Display units: force, length and speed factors and labels, and a damping coefficient.
    @property
    def force(self) -> tuple[float, str]:
        """(display value of 1 N, label) of the reader's force unit."""
        return self.units.force_per_n, self.units.force_label

    @property
    def length(self) -> tuple[float, str]:
        """(display value of 1 m, label) of the reader's length unit."""
        return self.units.length_per_m, self.units.length_label

    @property
    def speed(self) -> tuple[float, str]:
        """(display value of 1 m/s, label) of the reader's velocity unit."""
        return self.units.velocity_per_m_s, self.units.velocity_label

    @property
    def damping(self) -> tuple[float, str]:
        """(display value of 1 N·s/m, label) of a damping coefficient in the reader's units."""
        u = self.units
        if u.imperial:
            return u.force_per_n / u.length_per_m, f"{u.force_label}·s/{u.length_label}"
        return 1.0, "N·s/m"

    def plain(self, summary: str) -> str:
        """The words of a term with no text of its own: each moved parameter, in SI."""
        moved = [
            f"{p.name} {self.v(p.name):.3g}{self.sd(p.name)} {p.unit}".rstrip()
            for p in self.params
            if self.moved(p.name)
        ]
        return summary + (f" ({', '.join(moved)})" if moved else "")
