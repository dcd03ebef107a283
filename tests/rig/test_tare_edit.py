"""`rig tare --write`: the rig file's text with only the load cell's offset changed."""

from __future__ import annotations

from pathlib import Path

import pytest

from shockdyno.errors import ConfigError
from shockdyno.rig.config import parse_rig
from shockdyno.rig.tare import with_offset

RIGS = sorted((Path(__file__).resolve().parents[2] / "rigs").glob("*.toml"))


@pytest.mark.parametrize("path", RIGS, ids=[p.stem for p in RIGS])
def test_only_the_offset_changes(path: Path) -> None:
    text = path.read_text()
    edited = with_offset(text, -12.3456, str(path))
    before, after = parse_rig(text, "a"), parse_rig(edited, "b")
    assert after.daq.calibration.force_offset_n == pytest.approx(-12.346)
    assert after.daq.calibration.force_n_per_count == before.daq.calibration.force_n_per_count
    old, new = text.splitlines(), edited.splitlines()
    changed = [line for line in new if line not in old]
    assert len(changed) == 1 and changed[0].startswith("force_offset_n = -12.346")
    removed = [line for line in old if line not in new]
    assert len(removed) <= 1 and all(line.startswith("force_offset_n") for line in removed)
    assert sum(line.lstrip().startswith("#") for line in new) == sum(
        line.lstrip().startswith("#") for line in old
    )  # comments kept


def test_a_rig_file_without_the_table_is_refused() -> None:
    text = "\n".join(
        line for line in RIGS[0].read_text().splitlines() if "[daq.calibration]" not in line
    )
    with pytest.raises(ConfigError):
        with_offset(text, 1.0, "x.toml")
