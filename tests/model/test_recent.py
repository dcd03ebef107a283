"""model/recent.py: a result is reused only for exactly the same inputs, and reusing it
changes nothing a caller sees."""

from __future__ import annotations

import numpy as np
import pytest

from shockdyno.model import DamperModel, ModelInputs, chamber, flow, load_spec
from shockdyno.model.recent import Recent
from shockdyno.model.terms import make_term


class Counting:
    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, a: np.ndarray, b: np.ndarray, k: float) -> tuple[np.ndarray, float]:
        self.calls += 1
        return a * k + b, float(np.sum(a))


def test_the_same_inputs_are_computed_once_and_any_change_again() -> None:
    kernel = Counting()
    cached = Recent(kernel, size=4)
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=1000), rng.normal(size=1000)
    first = cached(a, b, 2.0)
    again = cached(a.copy(), b.copy(), 2.0)
    assert kernel.calls == 1 and cached.hits == 1
    assert np.array_equal(first[0], again[0]) and first[1] == again[1]
    # One element the fingerprint does not sample (it takes every 62nd), a scalar, a shape.
    nudged = a.copy()
    nudged[501] = np.nextafter(nudged[501], np.inf)
    cached(nudged, b, 2.0)
    cached(a, b, np.nextafter(2.0, 3.0))
    cached(a[:-1], b[:-1], 2.0)
    assert kernel.calls == 4
    # NaN matches NaN (a chamber's carry holds NaN for "no step before").
    a[3] = np.nan
    cached(a, b, 2.0)
    cached(a.copy(), b, 2.0)
    assert kernel.calls == 5


def test_a_record_keys_by_its_bits_and_an_unhashable_input_is_computed_each_time() -> None:
    """The chamber's constants are a NumPy record (unhashable as it is)."""
    calls: list[float] = []

    def kernel(a: np.ndarray, rec: object) -> np.ndarray:
        calls.append(float(rec["k"]))  # type: ignore[index]
        return a * rec["k"]  # type: ignore[index]

    cached = Recent(kernel)
    kind = np.dtype([("k", "f8"), ("n", "i8")])
    a = np.arange(5.0)
    cached(a, np.array((2.0, 1), dtype=kind)[()])
    again = cached(a, np.array((2.0, 1), dtype=kind)[()])
    assert calls == [2.0] and np.array_equal(again, a * 2.0)
    cached(a, np.array((np.nextafter(2.0, 3.0), 1), dtype=kind)[()])
    cached(a, np.array((2.0, 2), dtype=kind)[()])
    assert len(calls) == 3
    listed = Recent(lambda a, ks: a * ks[0])
    assert np.array_equal(listed(a, [3.0]), a * 3.0) and listed.calls == 0


def test_results_and_inputs_are_copies() -> None:
    kernel = Counting()
    cached = Recent(kernel)
    a, b = np.arange(10.0), np.ones(10)
    out, _ = cached(a, b, 3.0)
    out[:] = -1.0  # a caller editing its result in place
    a[0] = 99.0  # and then its input
    again, _ = cached(np.arange(10.0), np.ones(10), 3.0)
    assert kernel.calls == 1 and np.array_equal(again, np.arange(10.0) * 3 + 1)
    cached(a, b, 3.0)
    assert kernel.calls == 2


def test_it_holds_no_more_than_its_size_and_bytes() -> None:
    kernel = Counting()
    cached = Recent(kernel, size=2, max_bytes=4 * 8 * 100)
    ones = np.ones(10)
    for k in (1.0, 2.0, 3.0):
        cached(ones, ones, k)
    cached(ones, ones, 1.0)  # pushed out by 2 and 3
    assert kernel.calls == 4
    big = np.ones(200)  # beyond a quarter of the bytes: computed, never kept
    cached(big, big, 1.0)
    cached(big, big, 1.0)
    assert kernel.calls == 6


@pytest.mark.parametrize("air", [0.0, 0.01])
def test_a_friction_step_reuses_the_solve_and_the_chamber_bit_for_bit(air: float) -> None:
    """A parameter that acts after the flow (a seal's breakaway) repeats the flow solve's
    and the chamber's inputs: their results are reused, and the force is the one a fresh
    computation gives."""
    spec = load_spec()
    t = np.arange(0.0, 2.0, 0.002)
    x = 0.03 * np.sin(2 * np.pi * t)
    v = 0.03 * 2 * np.pi * np.cos(2 * np.pi * t)
    a = -0.03 * (2 * np.pi) ** 2 * np.sin(2 * np.pi * t)
    inputs = ModelInputs.single(x, v, a, 0.002)
    terms = (make_term("compressibility"), make_term("friction"))
    model = DamperModel(spec, terms).with_values(
        {"compressibility.air_fraction": air, "friction.breakaway_n": 20.0}
    )
    stepped = model.with_values({"friction.breakaway_n": 20.0 + 1e-3})
    model.force(inputs, 1e-6, 1e-6)
    solves, runs = flow._recent_signed.hits, chamber._recent_run.hits
    reused = stepped.force(inputs, 1e-6, 1e-6)
    assert flow._recent_signed.hits > solves
    assert chamber._recent_run.hits > runs or air == 0.0
    fresh_solve, fresh_run = flow._recent_signed, chamber._recent_run
    try:
        flow._recent_signed = Recent(flow._solve_signed, size=0)
        chamber._recent_run = Recent(chamber._run, size=0)
        fresh = stepped.force(inputs, 1e-6, 1e-6)
    finally:
        flow._recent_signed, chamber._recent_run = fresh_solve, fresh_run
    assert np.array_equal(reused, fresh)
