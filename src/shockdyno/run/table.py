"""The damper model's force-velocity table for every click (the model at a glance)."""

from __future__ import annotations

import numpy as np
from rich.table import Table

from shockdyno.model import DamperSpec, damper_force

TABLE_VELOCITIES_M_S = (-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3)


def click_table(spec: DamperSpec, gas_clicks: int = 0) -> Table:
    v = np.array(TABLE_VELOCITIES_M_S)
    zero = np.zeros_like(v)
    table = Table(
        title=f"{spec.name}: model force (N) vs velocity (m/s) at mid-stroke, gas clicks "
        f"{gas_clicks} (rebound < 0 < compression)"
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
