"""What the model works out once instead of at every evaluation (the plate's stiffness,
a model's parameter lookups, a derived model) is what working it out again gives."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.errors import ConfigError
from shockdyno.model import DamperModel, ModelInputs, load_spec
from shockdyno.model.composite import _samples
from shockdyno.model.shims import ShimStack, annular_plate_edge_stiffness
from shockdyno.model.terms import make_term


def _fresh_stiffness(v: ShimStack) -> float:
    plate = annular_plate_edge_stiffness.__wrapped__(
        v.thickness_m,
        v.outer_diameter_m / 2,
        v.clamp_diameter_m / 2,
        v.youngs_modulus_pa,
        v.poisson,
    )
    return float(v.n_shims * plate)


def test_a_valve_changed_by_name_has_every_new_field_and_its_own_plate() -> None:
    spec = load_spec()
    old = spec.compression_valve
    k0 = old.stiffness_n_per_m
    # Two fields of one valve at once (one copy of the valve holds both).
    moved = spec.with_values(
        {"compression_valve.preload_m": 2e-4, "compression_valve.face_area_m2": 3e-4}
    )
    assert (moved.compression_valve.preload_m, moved.compression_valve.face_area_m2) == (
        2e-4,
        3e-4,
    )
    assert moved.compression_valve.stiffness_n_per_m == k0 == _fresh_stiffness(old)
    assert moved.rebound_valve is spec.rebound_valve
    # A thicker plate is stiffer: the cached stiffness of the old one is not reused.
    thick = spec.with_values({"compression_valve.thickness_m": old.thickness_m * 1.1})
    k1 = thick.compression_valve.stiffness_n_per_m
    assert k1 > k0 and k1 == _fresh_stiffness(thick.compression_valve)
    with pytest.raises(ConfigError, match=r"compression_valve\.nope"):
        spec.with_values({"compression_valve.nope": 1.0})


def _inputs() -> ModelInputs:
    t = np.arange(0.0, 2.0, 0.002)
    w = 2 * np.pi
    x, v, a = 0.03 * np.sin(w * t), 0.03 * w * np.cos(w * t), -0.03 * w * w * np.sin(w * t)
    return ModelInputs(x, v, a, np.zeros(1, dtype=np.intp), np.array([0.002]), periodic=True)


def test_a_derived_model_is_the_model_built_from_scratch() -> None:
    spec = load_spec()
    terms = (make_term("friction"), make_term("compressibility"), make_term("gas_spring"))
    values = {"friction.breakaway_n": 30.0, "compressibility.air_fraction": 0.002}
    other = spec.with_values({"friction_n": spec.friction_n * 1.5})
    derived = DamperModel(spec, terms).with_spec(other).with_values(values)
    built = DamperModel(other, terms[::-1], values)
    assert [t.name for t in derived.terms] == [t.name for t in built.terms]
    assert derived.values == built.values and derived.param_list() == built.param_list()
    for t in terms:
        assert derived.local_values(t) == built.local_values(t)
    for name, _ in built.param_list():
        assert derived.value(name) == built.value(name)
    inputs = _inputs()
    f_derived = derived.force(inputs, 2e-6, 1e-6)
    f_built = built.force(inputs, 2e-6, 1e-6)
    assert np.array_equal(f_derived.view(np.int64), f_built.view(np.int64))
    with pytest.raises(ConfigError, match=r"friction\.nope"):
        derived.with_values({"friction.nope": 1.0})
    with pytest.raises(ConfigError, match=r"friction\.nope"):
        derived.value("friction.nope")


def test_a_terms_values_are_the_callers_to_edit() -> None:
    friction = make_term("friction")
    model = DamperModel(load_spec(), (friction,), {"friction.breakaway_n": 30.0})
    mine = model.local_values(friction)
    mine["breakaway_n"] = -1.0
    assert model.local_values(friction)["breakaway_n"] == 30.0
    # Another instance of the term (not the model's own) reads the same values by name.
    assert model.local_values(make_term("friction")) == model.local_values(friction)


def test_per_sample_areas_are_read_only_views_of_the_callers() -> None:
    """An area array per sample is used as given (never written into, by the model or
    through it), and gives the force its scalar gives."""
    inputs = _inputs()
    a_bc = np.full(inputs.size, 2e-6)
    seen = _samples(a_bc, inputs.size)
    assert np.shares_memory(seen, a_bc) and not seen.flags.writeable
    assert a_bc.flags.writeable  # the caller's own array keeps its flags
    with pytest.raises(ValueError):
        seen[0] = 0.0
    assert _samples(a_bc[::2], inputs.size // 2).flags.c_contiguous  # strided: copied
    model = DamperModel(load_spec())
    f_array = model.force(inputs, a_bc, np.full(inputs.size, 1e-6))
    assert np.array_equal(f_array, model.force(inputs, 2e-6, 1e-6))
