"""Display units: SI (mm/s, N, mm, °C) or imperial (in/s, lbf, in, °F).

Everything inside the project is SI (m, m/s, N, °C) and so is every JSON it writes; a
`Units` converts only at the edge, for a page, a terminal table or an exported table.
The standard velocities of a click chart are the ones a shop reads in that system:
25, 50, 100, 150, 200, 300 mm/s, or 1, 2, 3, 5, 10 in/s.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Sequence
from dataclasses import dataclass

from shockdyno.errors import ConfigError

M_PER_IN = 0.0254
N_PER_LBF = 4.4482216152605


@dataclass(frozen=True)
class Units:
    """A display unit system: label and factor from SI for velocity, force and length (display
    value of 1 m/s, 1 N, 1 m), the temperature's label, and a click chart's standard velocities
    (m/s)."""

    name: str
    velocity_label: str
    velocity_per_m_s: float  # display value of 1 m/s
    force_label: str
    force_per_n: float
    length_label: str
    length_per_m: float
    temperature_label: str
    standard_velocities_m_s: tuple[float, ...]  # speeds of a click chart, m/s

    @property
    def imperial(self) -> bool:
        """Whether this is the imperial system (in/s, lbf, in, °F)."""
        return self.name == "imperial"

    def velocity(self, v_m_s: float) -> float:
        """A velocity in m/s, in this system's velocity unit."""
        return v_m_s * self.velocity_per_m_s

    def force(self, f_n: float) -> float:
        """A force in N, in this system's force unit."""
        return f_n * self.force_per_n

    def length(self, x_m: float) -> float:
        """A length in m, in this system's length unit."""
        return x_m * self.length_per_m

    def temperature(self, t_c: float) -> float:
        """A temperature in °C, in this system's (°F for imperial)."""
        return t_c * 9.0 / 5.0 + 32.0 if self.imperial else t_c

    def temperature_to_c(self, t: float) -> float:
        """A temperature given in these units, in °C."""
        return (t - 32.0) * 5.0 / 9.0 if self.imperial else t

    def speed_text(self, v_m_s: float) -> str:
        """'50 mm/s' or '2 in/s' (3 significant digits, no trailing zeros)."""
        return f"{self.velocity(abs(v_m_s)):.3g} {self.velocity_label}"

    def force_text(self, f_n: float, signed: bool = False) -> str:
        """'231 N' or '52 lbf' (whole units; with `signed`, a sign always)."""
        return f"{self.force(f_n):{'+' if signed else ''}.0f} {self.force_label}"


SI = Units(
    name="si",
    velocity_label="mm/s",
    velocity_per_m_s=1e3,
    force_label="N",
    force_per_n=1.0,
    length_label="mm",
    length_per_m=1e3,
    temperature_label="°C",
    standard_velocities_m_s=(0.025, 0.05, 0.1, 0.15, 0.2, 0.3),
)

IMPERIAL = Units(
    name="imperial",
    velocity_label="in/s",
    velocity_per_m_s=1.0 / M_PER_IN,
    force_label="lbf",
    force_per_n=1.0 / N_PER_LBF,
    length_label="in",
    length_per_m=1.0 / M_PER_IN,
    temperature_label="°F",
    standard_velocities_m_s=tuple(v * M_PER_IN for v in (1.0, 2.0, 3.0, 5.0, 10.0)),
)

UNITS: dict[str, Units] = {"si": SI, "imperial": IMPERIAL}


def signed_velocities(speeds: Sequence[float]) -> tuple[float, ...]:
    """A click chart's columns: rebound (fastest first) then compression (slowest first)."""
    return tuple([-s for s in sorted(speeds, reverse=True)] + sorted(speeds))


# A force or speed inside a sentence the diagnosis wrote in SI (a finding's why_not,
# what separates two terms): "0.017 N", "25 mm/s". Nothing else there carries a display unit.
_SI_QUANTITY = re.compile(r"(-?\d+(?:\.\d+)?(?:e[-+]?\d+)?) (N|mm/s)\b")


def in_units(text: str, u: Units = SI) -> str:
    """An SI sentence of the diagnosis with its forces and speeds in `u`."""
    if not u.imperial:
        return text

    def convert(m: re.Match[str]) -> str:
        value = float(m.group(1))
        # As many significant digits as the SI text gave: no more precision than it had.
        digits = re.sub(r"e.*|[-.]", "", m.group(1)).lstrip("0")
        spec = f".{max(len(digits), 1)}g"
        if m.group(2) == "N":
            return f"{format(u.force(value), spec)} {u.force_label}"
        return f"{format(u.velocity(value / 1e3), spec)} {u.velocity_label}"

    return _SI_QUANTITY.sub(convert, text)


def get(name: str) -> Units:
    """The unit system by name (`si`, `imperial`); ConfigError for another."""
    try:
        return UNITS[name]
    except KeyError:
        raise ConfigError(f"unknown units {name!r}: use si or imperial") from None


def add_argument(parser: argparse.ArgumentParser, what: str = "tables and plots") -> None:
    """`--units si|imperial` (default si); read it back with `get(args.units)`."""
    parser.add_argument(
        "--units",
        choices=tuple(UNITS),
        default="si",
        help=f"{what} in mm/s, N, mm, °C (si) or in/s, lbf, in, °F (imperial); JSON stays SI",
    )
