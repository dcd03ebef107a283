"""A spec with an adjuster per bleed path: each path's area follows its own adjuster."""

from __future__ import annotations

from pathlib import Path

import pytest

from shockdyno.errors import ConfigError
from shockdyno.model.spec import default_spec_path, load_spec

BLEED = "area_closed_m2 = 0.0\narea_open_m2 = 1e-6\nshape_clicks = 1.0\n"
BLEEDS = f"[bleed.compression]\n{BLEED}[bleed.rebound]\n{BLEED}"
TWO = Path(__file__).resolve().parents[2] / "sim" / "two-adjuster.toml"


def test_each_path_follows_its_own_adjuster() -> None:
    spec = load_spec(TWO)
    assert spec.adjuster_names == ("compression", "rebound")
    assert spec.adjuster_on("compression") == "compression"
    # The law is the path's: A(n) of the compression table at the compression clicks only.
    bc, bt = spec.setting_areas({"compression": 5, "rebound": 0})
    bc2, bt2 = spec.setting_areas({"compression": 5, "rebound": 20})
    assert bc == bc2 == pytest.approx(float(spec.compression_bleed.area(5)))
    assert bt == 0.0 and bt2 == pytest.approx(4.0e-6)
    # closed form of the saturating law at the last click: the open area
    assert spec.setting_areas({"compression": 20, "rebound": 3})[0] == pytest.approx(1.2e-5)


def test_a_spec_without_adjusters_is_the_one_needle() -> None:
    spec = load_spec(default_spec_path())
    assert spec.adjusters == () and spec.adjuster_on("compression") == ""


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ({"compression": 5}, "has adjusters compression, rebound; got a setting of compression"),
        ({"compression": 21, "rebound": 0}, "compression clicks must be 0-20, got 21"),
        ({"compression": 1, "rebound": 0, "hs": 2}, "got a setting of"),
    ],
)
def test_a_bad_setting_is_one_line(setting: dict[str, int], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        load_spec(TWO).setting_areas(setting)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('acts_on = "rebound"', 'acts_on = "compression"', "another adjuster already acts on"),
        ('acts_on = "rebound"', 'acts_on = "gas"', r"adjuster.rebound.acts_on: must be one of"),
        ("[adjuster.rebound]", "[adjuster.Rebound]", "adjuster.Rebound: an adjuster's name"),
        (
            "max_clicks = 20                  # assumed: a 20-click r",
            "max_clicks = -1 #",
            "max_clicks",
        ),
        ("[adjuster.compression]", BLEEDS + "[adjuster.compression]", "drop \\[bleed\\]"),
    ],
)
def test_bad_adjuster_tables_are_named(tmp_path: Path, old: str, new: str, message: str) -> None:
    text = TWO.read_text()
    assert old in text
    p = tmp_path / "bad.toml"
    p.write_text(text.replace(old, new, 1))
    with pytest.raises(ConfigError, match=message) as exc:
        load_spec(p)
    assert "\n" not in str(exc.value) and "bad.toml" in str(exc.value)
