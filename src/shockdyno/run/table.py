"""The damper model's force-velocity table for every click (the model at a glance)."""

from __future__ import annotations

import numpy as np
from rich.table import Table

from shockdyno.model import DamperSpec, damper_force

TABLE_VELOCITIES_M_S = (-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3)


def click_table(spec: DamperSpec, gas_clicks: int = 0) -> Table:
    """The model's force (N, gas force included, compression positive) at ±0.05-0.3 m/s at
    mid-stroke, and both bleed areas (mm²), for every rod click at `gas_clicks`: a rich table."""
    v = np.array(TABLE_VELOCITIES_M_S)
    zero = np.zeros_like(v)
    # Raw force, as a load cell reads it: the sweep's lines and the reports show damping
    # force, this less the gas force, so the title says which (issue 47.8).
    rest = damper_force(spec, np.zeros(1), np.zeros(1), np.zeros(1), *spec.bleed_areas(0, 0))
    gas = float(np.asarray(rest).reshape(-1)[0])
    table = Table(
        title=f"{spec.name}: model force (N), raw: the {gas:.0f} N gas force included "
        f"(damping force = this − {gas:.0f} N, as sweeps and reports show it), vs velocity "
        f"(m/s) at mid-stroke, gas clicks {gas_clicks} (rebound < 0 < compression)"
    )
    table.add_column("clicks", justify="right")
    table.add_column("A_bc mm²", justify="right")
    table.add_column("A_bt mm²", justify="right")
    for vel in v:
        table.add_column(f"{vel:+.2f}", justify="right")
    for n in range(spec.compression_bleed.max_clicks + 1):
        a_bc, a_bt = spec.bleed_areas(n, gas_clicks)
        f = damper_force(spec, zero, v, zero, a_bc, a_bt)
        table.add_row(
            str(n), f"{float(a_bc) * 1e6:.2f}", f"{float(a_bt) * 1e6:.2f}", *(f"{x:.0f}" for x in f)
        )
    return table
