"""The calibration's parameter set: names in, names out, the optimiser's vector between."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.errors import ConfigError
from shockdyno.fit.parameters import (
    AREA_BC,
    AREA_BT,
    DEFAULT_GLOBALS,
    GLOBAL,
    TERM,
    Parameter,
    ParameterSet,
    calibration_set,
    global_parameters,
    spec_global,
)
from shockdyno.model.spec import load_spec


def _set() -> ParameterSet:
    return calibration_set(
        [
            Parameter("gas_pressure_pa", GLOBAL, 1.6e6, 1.6e6, 0.2, 5.0),
            Parameter("friction_n", GLOBAL, 35.0, 35.0, 0.0, 4.0),
        ],
        {"friction.breakaway_n": (25.0, 10.0, 0.0, 100.0)},
        np.array([1e-7, 2e-7, 3e-7]),
        np.array([4e-7, 5e-7, 6e-7]),
        1e-6,
        8e-5,
    )


def test_the_vector_is_the_values_over_their_scales_in_kind_order() -> None:
    ps = _set()
    assert len(ps) == 2 + 1 + 3 + 3
    theta = ps.theta0()
    assert theta[ps.span(GLOBAL)] == pytest.approx([1.0, 1.0])
    assert theta[ps.span(TERM)] == pytest.approx([2.5])
    assert theta[ps.span(AREA_BC)] == pytest.approx([0.1, 0.2, 0.3])
    assert theta[ps.span(AREA_BT)] == pytest.approx([0.4, 0.5, 0.6])
    assert ps.span(GLOBAL, TERM) == slice(0, 3)
    lb, ub = ps.bounds()
    assert list(lb) == [0.2, 0.0, 0.0, 0, 0, 0, 0, 0, 0]
    assert ub[-1] == pytest.approx(80.0)  # a_max in the areas' scale
    assert [p.name for p in ps.of(AREA_BT)] == ["A_bt[0]", "A_bt[1]", "A_bt[2]"]


def test_a_moved_vector_comes_back_by_name_in_its_own_units() -> None:
    ps = _set()
    theta = ps.theta0()
    theta[ps.span(TERM)] = 4.0
    theta[ps.span(AREA_BC)] *= 2
    assert ps.values(theta, GLOBAL) == {"gas_pressure_pa": 1.6e6, "friction_n": 35.0}
    assert ps.values(theta, TERM) == {"friction.breakaway_n": 40.0}
    assert ps.vector(theta, AREA_BC) == pytest.approx([2e-7, 4e-7, 6e-7])
    assert ps.vector(theta, AREA_BT) == pytest.approx([4e-7, 5e-7, 6e-7])


def test_the_order_given_within_a_kind_is_kept_whatever_order_kinds_come_in() -> None:
    ps = calibration_set(
        [Parameter("b", GLOBAL, 1.0, 1.0, 0, 2), Parameter("a", GLOBAL, 2.0, 1.0, 0, 3)],
        {},
        np.zeros(0),
        np.zeros(0),
        1e-6,
        1e-4,
    )
    assert [p.name for p in ps.items] == ["b", "a"]
    assert ps.span(TERM) == slice(2, 2) and ps.values(ps.theta0(), TERM) == {}


def test_a_spec_global_is_declared_once_read_and_set_by_name() -> None:
    spec = load_spec()
    got = {p.name: p for p in global_parameters(spec)}
    assert tuple(got) == DEFAULT_GLOBALS
    gas = got["gas_pressure_pa"]
    assert (gas.value, gas.scale, gas.unit) == (spec.gas_pressure_pa, spec.gas_pressure_pa, "Pa")
    assert spec_global("gas_pressure_pa").bounds(1e6) == (2e5, 5e6)
    preload = got["rebound_valve.preload_m"]
    assert preload.value == spec.rebound_valve.preload_m and preload.unit == "m"
    moved = spec.with_values({"rebound_valve.preload_m": 2e-4, "friction_n": 12.0})
    assert moved.value("rebound_valve.preload_m") == 2e-4 and moved.friction_n == 12.0
    assert moved.compression_valve == spec.compression_valve  # the other valve untouched
    for bad in ("friction", "rebound_valve.colour", "name", "rebound_valve"):
        with pytest.raises(ConfigError, match="unknown damper parameter"):
            spec.value(bad)
