"""The term library: physics the paper's model leaves out, by interface name.

Names are an interface (fit --terms, the fit JSON's `terms`, diagnose's findings):
compressibility, thermal, friction, cavitation, sensor_lag, gas_spring, contact,
position_force, fixture_mass.
"""

from __future__ import annotations

from shockdyno.errors import ConfigError
from shockdyno.model.composite import Term
from shockdyno.model.terms.cavitation import Cavitation
from shockdyno.model.terms.compressibility import Compressibility
from shockdyno.model.terms.contact import Contact
from shockdyno.model.terms.fixture_mass import FixtureMass
from shockdyno.model.terms.friction import Friction
from shockdyno.model.terms.gas_spring import GasSpring
from shockdyno.model.terms.position_force import PositionForce
from shockdyno.model.terms.sensor_lag import SensorLag
from shockdyno.model.terms.thermal import Thermal

LIBRARY: dict[str, type[Term]] = {
    cls.name: cls
    for cls in (
        Compressibility,
        Thermal,
        Friction,
        Cavitation,
        SensorLag,
        GasSpring,
        Contact,
        PositionForce,
        FixtureMass,
    )
}


def make_term(name: str) -> Term:
    """A new term of the library by its interface name; ConfigError naming the known ones."""
    cls = LIBRARY.get(name)
    if cls is None:
        raise ConfigError(f"unknown physics term {name!r} (one of {', '.join(LIBRARY)})")
    return cls()


__all__ = [
    "LIBRARY",
    "Cavitation",
    "Compressibility",
    "Contact",
    "FixtureMass",
    "Friction",
    "GasSpring",
    "PositionForce",
    "SensorLag",
    "Thermal",
    "make_term",
]
