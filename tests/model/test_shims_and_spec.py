"""Shim-stack plate theory and the damper spec file."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from shockdyno.errors import ConfigError
from shockdyno.model import default_spec_path, load_spec
from shockdyno.model.shims import annular_plate_edge_stiffness


def test_narrow_annulus_stiffness_tends_to_cantilever_strip():
    """For a clamp close to the rim the plate is a cantilever of length a-b and width 2πa."""
    t, a, e, nu = 0.25e-3, 0.02, 206e9, 0.3
    b = a * 0.995
    beam = 3 * e * (2 * math.pi * a * t**3 / 12 / (1 - nu**2)) / (a - b) ** 3
    assert annular_plate_edge_stiffness(t, a, b, e, nu) == pytest.approx(beam, rel=0.01)


def test_stiffness_scales_with_thickness_cubed_and_falls_with_diameter():
    k1 = annular_plate_edge_stiffness(0.25e-3, 0.02, 0.01, 206e9, 0.3)
    k2 = annular_plate_edge_stiffness(0.5e-3, 0.02, 0.01, 206e9, 0.3)
    assert k2 / k1 == pytest.approx(8.0, rel=1e-9)
    assert annular_plate_edge_stiffness(0.25e-3, 0.018, 0.01, 206e9, 0.3) > k1


def test_default_spec_has_paper_values():
    spec = load_spec()
    assert spec.piston_diameter_m == 0.040
    assert spec.compression_valve.n_shims == 7 and spec.rebound_valve.n_shims == 7
    assert spec.compression_valve.outer_diameter_m == 0.040
    assert spec.rebound_valve.outer_diameter_m == 0.036
    assert spec.oil_viscosity_cst == 11.0
    assert spec.bleed_bore_diameter_m == 0.009


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("not toml [[[", "not valid TOML"),
        ("[damper]\nname='x'\n", "bad.toml: valves: missing"),
    ],
)
def test_bad_spec_files_give_one_line_errors(tmp_path, text, message):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")) as exc:
        load_spec(p)
    assert "\n" not in str(exc.value)


def test_unknown_and_missing_keys_are_named(tmp_path):
    src = default_spec_path().read_text()
    p = tmp_path / "typo.toml"
    p.write_text(src.replace("friction_n =", "frcition_n ="))
    with pytest.raises(
        ConfigError, match=r"damper.frcition_n: unknown key \(did you mean friction_n"
    ):
        load_spec(p)
    p.write_text(src.replace("rod_diameter_m = 0.014", "rod_diameter_m = 0.05"))
    with pytest.raises(ConfigError, match="rod must be thinner"):
        load_spec(p)
    with pytest.raises(ConfigError, match="not found"):
        load_spec(tmp_path / "nope.toml")


def test_clicks_out_of_range_are_refused():
    spec = load_spec()
    with pytest.raises(ConfigError, match="rod clicks must be 0-21"):
        spec.bleed_areas(22)
    with pytest.raises(ConfigError, match="gas-bottle clicks"):
        spec.bleed_areas(3, -1)


@pytest.mark.parametrize(
    ("key", "line", "message"),
    [
        (
            "oil_viscosity_cst",
            'oil_viscosity_cst = "ten"',
            "damper.oil_viscosity_cst: must be a number > 0, got 'ten'",
        ),
        ("n_shims", "n_shims = 6.5", "n_shims: must be a whole number >= 1, got 6.5"),
        ("max_clicks", 'max_clicks = "24"', "max_clicks: must be a whole number >= 1, got '24'"),
        ("friction_n", "friction_n = true", "damper.friction_n: must be a number >= 0, got true"),
    ],
)
def test_a_value_of_the_wrong_type_is_one_line_naming_the_key(tmp_path, key, line, message):
    """A quoted number, a fraction where a count goes, a true/false: refused on reading
    (a fit with "ten" crashed in the flow solve; 6.5 shims ran as 6.5)."""
    lines = default_spec_path().read_text().splitlines()
    at = next(i for i, text in enumerate(lines) if text.strip().startswith(key))
    lines[at] = line
    bad = tmp_path / "bad.toml"
    bad.write_text("\n".join(lines))
    with pytest.raises(ConfigError) as err:
        load_spec(bad)
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [  # each of these used to load and fail later (a traceback in fit) or never
        ("oil_viscosity_cst = 11.0", "oil_viscosity_cst = 0",
         "damper.oil_viscosity_cst: must be a number > 0"),
        ("gas_length_m = 0.050", "gas_length_m = 0.0", "damper.gas_length_m: must be a number > 0"),
        ('name = "ohlins-s46"', 'name = ""', "damper.name: must be non-empty text"),
        ("clamp_diameter_m = 0.020", "clamp_diameter_m = 0.050",
         "valves.compression.clamp_diameter_m: 50 mm must be less than"),
        ("seat_diameter_m = 0.036", "seat_diameter_m = 0.5",
         "valves.compression.seat_diameter_m: 500 mm must lie between"),
        ("rod_diameter_m = 0.014", "rod_diameter_m = 0.05",
         "damper.rod_diameter_m: 50 mm must be thinner"),
    ],
)  # fmt: skip
def test_a_spec_that_would_break_the_model_is_refused_naming_the_key(
    tmp_path: Path, old: str, new: str, message: str
) -> None:
    src = default_spec_path().read_text()
    assert old in src
    p = tmp_path / "bad.toml"
    p.write_text(src.replace(old, new, 1))
    with pytest.raises(ConfigError) as info:
        load_spec(p)
    assert str(info.value).startswith(f"{p}: ") and message in str(info.value), info.value
