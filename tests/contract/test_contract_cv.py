"""Constant-velocity strokes on the simulated rig (issue 47): the drive's function
generator over Modbus, the samples over socket://, the session's safety around them."""

from __future__ import annotations

import numpy as np
import pytest
from contract_helpers import Collector, drive_status

from shockdyno.model.stroke import Stroke
from shockdyno.run.plan import stroke_frequency_hz
from shockdyno.run.session import RigSession


def test_a_triangle_runs_at_its_speed_and_ctrl_c_leaves_the_ram_centred_and_off(
    sim_rig_factory,
) -> None:
    rig = sim_rig_factory(serial="socket", speed=20.0).rig_config()
    stroke = Stroke("triangle", 0.02, 0.15)
    f = stroke_frequency_hz(stroke)
    rec = Collector()
    with RigSession(rig, strokes=[stroke]) as session:
        out = session.run_sine(0.02, f, 1, 2, rec.block, rec.act, waveform=stroke)
        assert out.status == "complete", out.reason
        b = rec.all
        keep = (b.t_s >= out.measured_start_s) & (b.t_s <= out.measured_end_s)
        v = np.gradient(b.displacement_m[keep], b.t_s[keep])
        # Most of the time at ±v, never much beyond it (the servo's overshoot at a reversal)
        at_speed = np.abs(np.abs(v) - 0.15) < 0.01
        assert np.mean(at_speed) > 0.8
        assert np.max(np.abs(rec.all.displacement_m)) < 0.0205
        commands = [fields for _, fields in rec.actuator if "cmd_waveform" in fields]
        assert commands and commands[0]["cmd_velocity_m_s"] == 0.15

        seen = [0]

        def interrupt(block) -> None:
            seen[0] += len(block)
            if seen[0] > 700:
                raise KeyboardInterrupt

        with pytest.raises(KeyboardInterrupt):
            session.run_sine(0.02, f, 2, 4, interrupt, waveform=stroke)
    st = drive_status(rig)
    assert not st.enabled and not st.running
    assert st.position_m == pytest.approx(rig.stroke_centre_m, abs=1e-3)
    assert [e.kind for e in session.events][-2:] == ["disable", "closed"]
    starts = [e.message for e in session.events if e.kind == "start"]
    assert starts[0] == f"triangle 20 mm at 150 mm/s ({f:g} Hz)"


def test_a_sine_after_a_triangle_is_a_sine(sim_rig_factory) -> None:
    """The waveform register is written for every test: a drive left in triangle mode must
    not run a triangle when a sine is asked for."""
    rig = sim_rig_factory(serial="socket", speed=20.0).rig_config()
    stroke = Stroke("triangle", 0.02, 0.1)
    with RigSession(rig, strokes=[stroke]) as session:
        session.run_sine(0.02, stroke_frequency_hz(stroke), 0, 1, lambda b: None, waveform=stroke)
        rec = Collector()
        out = session.run_sine(0.02, 1.0, 1, 2, rec.block)
        assert out.status == "complete", out.reason
    b = rec.all
    keep = (b.t_s >= out.measured_start_s) & (b.t_s <= out.measured_end_s)
    t, x = b.t_s[keep], b.displacement_m[keep]
    w = 2 * np.pi * 1.0
    basis = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    # A sine fits a sine to the LVDT's noise; a triangle of the same amplitude leaves
    # about 0.5 mm of residual.
    assert np.std(x - basis @ coef) < 2e-4
