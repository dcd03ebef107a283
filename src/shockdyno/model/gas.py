"""Gas chamber and compression-chamber pressure (eq. 5-6)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from shockdyno.model.spec import DamperSpec

FloatArray = NDArray[np.float64]


def gas_pressure(spec: DamperSpec, x: FloatArray) -> FloatArray:
    """Eq. 5: isothermal gas pressure as the rod enters (x > 0) and shrinks the gas volume."""
    v0 = spec.gas_volume_m3
    return np.asarray(spec.gas_pressure_pa * v0 / (v0 - spec.rod_area_m2 * x), dtype=float)


def compression_pressure(spec: DamperSpec, x: FloatArray, a: FloatArray) -> FloatArray:
    """Eq. 6: the gas pressure plus the force that accelerates the floating gas piston.

    The gas piston moves z = x A_rod / A_gp, so it needs (p_c - p_g) A_gp = m_gp z̈.
    """
    inertia = spec.rod_area_m2 * spec.gas_piston_mass_kg / spec.gas_piston_area_m2**2
    return np.asarray(inertia * a + gas_pressure(spec, x), dtype=float)
