"""docs/spec.md: its example loads, and it names every key a spec file may hold."""

from __future__ import annotations

import re
from dataclasses import fields
from pathlib import Path

from shockdyno.model.bleed import BleedLaw
from shockdyno.model.shims import ShimStack
from shockdyno.model.spec import DamperSpec, load_spec

DOC = Path(__file__).resolve().parents[2] / "docs" / "spec.md"


def test_example_loads(tmp_path: Path) -> None:
    text = DOC.read_text()
    example = re.search(r"## Example.*?```toml\n(.*?)```", text, re.S)
    assert example
    path = tmp_path / "mine.toml"
    path.write_text(example.group(1))
    spec = load_spec(path)
    assert spec.name == "my-46mm-monotube"
    assert spec.piston_diameter_m == 0.046
    assert spec.compression_bleed.max_clicks == 24


def test_every_key_is_documented() -> None:
    text = DOC.read_text()
    nested = {"compression_valve", "rebound_valve", "compression_bleed", "rebound_bleed"}
    keys = [f.name for f in fields(DamperSpec) if f.name not in nested]
    keys += [f.name for f in fields(ShimStack)] + [f.name for f in fields(BleedLaw)]
    missing = [k for k in keys if f"| `{k}` |" not in text]
    assert not missing, f"docs/spec.md does not describe {missing}"
