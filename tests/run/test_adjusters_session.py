"""The session sets a damper's own adjusters: each NAME_clicks register written and read
back on a motorised rig (the simulated damper's areas follow), one prompt naming every
adjuster on an operator's; a motorised rig without a register is refused before the rig."""

from __future__ import annotations

from pathlib import Path

import pytest

from shockdyno.errors import ConfigError, RigFault
from shockdyno.model.spec import load_spec
from shockdyno.rig.config import load_rig, parse_rig
from shockdyno.run.plan import SweepPlan, parse_adjust
from shockdyno.run.recording import record_sweep
from shockdyno.run.session import RigSession
from shockdyno.simrig import start_sim_rig

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "rigs" / "sim.toml"
SPEC = REPO / "sim" / "two-adjuster.toml"


def test_motorised_adjusters_move_the_simulated_dampers_areas() -> None:
    spec = load_spec(SPEC)
    with (
        start_sim_rig(SIM_RIG, spec_path=SPEC, speed=20) as sim,
        RigSession(sim.rig_config()) as session,
    ):
        session.set_adjusters({"compression": 3, "rebound": 17}, 0)
        assert sim.engine.state.areas == spec.setting_areas({"compression": 3, "rebound": 17})
        session.set_adjusters({"compression": 3, "rebound": 2}, 0)
        bc, bt = sim.engine.state.areas
        assert bc == spec.setting_areas({"compression": 3, "rebound": 0})[0]  # unmoved
        assert bt == spec.setting_areas({"compression": 0, "rebound": 2})[1]
        # past its range: the simulated drive refuses the write, as a real one would
        with pytest.raises(RigFault, match=r"write rebound_clicks = 21 .* refused"):
            session.set_adjusters({"compression": 3, "rebound": 21}, 0)


def test_an_operator_is_asked_once_for_every_adjuster() -> None:
    text = SIM_RIG.read_text().replace('adjuster = "motorised"', 'adjuster = "operator"')
    asked: list[str] = []
    with (
        start_sim_rig(parse_rig(text, "op.toml"), spec_path=SPEC, speed=20) as sim,
        RigSession(sim.rig_config(), prompt=asked.append) as session,
    ):
        session.set_adjusters({"compression": 5, "rebound": 10}, 0)
    assert asked == [
        "Set the compression adjuster to 5 clicks, the rebound adjuster to 10 clicks "
        "and the gas bottle to 0 clicks"
    ]


def test_a_motorised_rig_without_the_register_is_refused_before_anything(tmp_path: Path) -> None:
    text = SIM_RIG.read_text()
    rig = parse_rig(text.replace("rebound_clicks = {", "# rebound_clicks = {"), "norebound.toml")
    assert load_rig(SIM_RIG).registers.registers["rebound_clicks"]
    plan = SweepPlan(
        clicks=(),
        frequencies_hz=(1.0,),
        adjust=parse_adjust(["compression=0", "rebound=0"], {"compression": 20, "rebound": 20}),
    )
    out = tmp_path / "x.mcap"
    with pytest.raises(ConfigError, match="has no rebound_clicks"):
        record_sweep(rig, plan, out, metadata={})
    assert not out.exists()


def test_any_adjusters_register_is_named_for_it_and_a_misspelt_one_still_refused() -> None:
    text = SIM_RIG.read_text()
    extra = 'bump_clicks = { address = 44, type = "uint16" }\n'  # a free address
    rig = parse_rig(text.replace("[daq]\n", extra + "\n[daq]\n", 1), "bump.toml")
    assert "bump_clicks" in rig.registers.registers
    with pytest.raises(ConfigError, match="unknown register"):
        parse_rig(text.replace("[daq]\n", extra.replace("_clicks", "_clickz") + "\n[daq]\n", 1))
