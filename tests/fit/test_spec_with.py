"""A problem's spec for a fit's globals is the base with those values, whether built or
given back from the last few asked for."""

from __future__ import annotations

from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.problem import SPECS_KEPT, StackedProblem
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model import load_spec


def test_the_spec_of_the_same_globals_is_given_back_and_of_others_built() -> None:
    spec = load_spec()
    prepared, _ = prepare_tests(synthetic_sweep(spec, [4], cycles=2, seed=5), 100.0)
    prob = StackedProblem(spec, prepared)
    globals_ = {"friction_n": 20.0, "compression_valve.preload_m": 2e-4}
    first = prob.spec_with(globals_)
    assert first == spec.with_values(globals_)
    assert prob.spec_with(dict(globals_)) is first  # the same values: the same spec
    nudged = prob.spec_with({**globals_, "friction_n": 20.000000000000004})
    assert nudged is not first and nudged.friction_n == 20.000000000000004
    # Zero and minus zero are equal numbers with other bits: each its own spec.
    plus, minus = prob.spec_with({"friction_n": 0.0}), prob.spec_with({"friction_n": -0.0})
    assert plus is not minus and str(minus.friction_n) == "-0.0"
    # A new base: its own specs, none of the old base's.
    other = prob.with_base(spec.with_values({"gas_pressure_pa": 2.0e6}))
    moved = other.spec_with(globals_)
    assert moved.gas_pressure_pa == 2.0e6 and moved.friction_n == 20.0
    assert prob.spec_with(globals_) is first
    # Only the last few are kept: the oldest is built again, the same values.
    for k in range(SPECS_KEPT):
        prob.spec_with({"friction_n": 30.0 + k})
    again = prob.spec_with(globals_)
    assert again is not first and again == first
