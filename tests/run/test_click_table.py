"""`shockdyno demo --table`: the model's force-velocity table for every click."""

from __future__ import annotations

import numpy as np

from shockdyno.cli import main
from shockdyno.model import damper_force, load_spec
from shockdyno.run.table import TABLE_VELOCITIES_M_S


def test_table_has_every_click_with_the_models_forces(capsys):
    assert main(["demo", "--table"]) == 0
    out = capsys.readouterr().out
    rows = {}
    for line in out.splitlines():
        cells = [c.strip() for c in line.strip("│┃ ").split("│")]
        if len(cells) == 3 + len(TABLE_VELOCITIES_M_S) and cells[0].isdigit():
            rows[int(cells[0])] = [float(c) for c in cells[1:]]
    assert sorted(rows) == list(range(22))
    spec = load_spec()
    v = np.array(TABLE_VELOCITIES_M_S)
    for clicks in (0, 7, 21):
        a_bc, a_bt = spec.bleed_areas(clicks)
        expected = damper_force(spec, 0 * v, v, 0 * v, a_bc, a_bt)
        np.testing.assert_allclose(rows[clicks][2:], expected, atol=0.5)  # printed to 1 N
        assert rows[clicks][0] == round(float(a_bc) * 1e6, 2)
