"""A Jacobian's chamber columns, each a Newton step a chamber step from the first
integration's trajectory (model/chamber.linearised), are the solved columns to within the
solved columns' own finite-difference error; the block changes nothing outside it, and its
results do not depend on what the cache held."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from shockdyno.model import DamperModel, ModelInputs, chamber, load_spec
from shockdyno.model.recent import Recent
from shockdyno.model.terms import make_term

SPEC = load_spec()
A_BC, A_BT = 2e-6, 1e-6


def sweep() -> ModelInputs:
    """Three tests (1 kHz, periodic whole cycles) at 0.5, 1 and 1.5 Hz."""
    parts = []
    for f in (0.5, 1.0, 1.5):
        t = np.arange(int(2000 / f)) / 1000.0
        w = 2 * np.pi * f
        one = ModelInputs.single(
            0.03 * np.sin(w * t), 0.03 * w * np.cos(w * t), -0.03 * w * w * np.sin(w * t), 1e-3
        )
        parts.append(replace(one, periodic=True))
    return ModelInputs.stack(parts)


# Air alone; air with vapour at a release pressure the rebound stroke reaches (a low charge).
CASES = {
    "air": ({"compressibility.air_fraction": 0.01}, SPEC),
    "air and vapour": (
        {"compressibility.air_fraction": 0.005, "cavitation.release_pressure_pa": 3.0e5},
        SPEC.with_values({"gas_pressure_pa": 6.0e5}),
    ),
}
STEPS = {
    "compressibility.air_fraction": 1e-6,
    "compressibility.oil_compressibility_per_gpa": 1e-6,
    "gas_pressure_pa": 1e-6,
    "compression_valve.preload_m": 1e-6,
    "cavitation.release_pressure_pa": 1e-6,
}


def model_for(case: str) -> DamperModel:
    values, spec = CASES[case]
    terms = tuple(make_term(t) for t in {k.split(".")[0] for k in values})
    return DamperModel(spec, terms, values)


def moved(model: DamperModel, key: str, rel: float) -> DamperModel | None:
    """`model` with one value moved by a relative `rel` (None: a term it lacks)."""
    term = key.split(".")[0]
    if term in {"compressibility", "cavitation"}:
        if model.term(term) is None:
            return None
        return model.with_values({key: model.value(key) * (1 + rel)})
    return model.with_spec(model.spec.with_values({key: model.spec.value(key) * (1 + rel)}))


@pytest.mark.parametrize("case", list(CASES))
def test_guided_columns_are_the_solved_ones_within_their_own_error(case: str) -> None:
    inputs = sweep()
    model = model_for(case)
    base = model.force(inputs, A_BC, A_BT)
    if case == "air and vapour":
        assert np.any(model.evaluate(inputs, A_BC, A_BT).outputs["cavitation.vapour_m3"] > 0)
    for key, rel in STEPS.items():
        m, fine = moved(model, key, rel), moved(model, key, rel / 10)
        if m is None or fine is None:
            continue
        solved = (m.force(inputs, A_BC, A_BT) - base) / rel
        finer = (fine.force(inputs, A_BC, A_BT) - base) / (rel / 10)
        with chamber.linearised():
            model.force(inputs, A_BC, A_BT)  # the first: the guide
            guided = (m.force(inputs, A_BC, A_BT) - base) / rel
        scale = float(np.linalg.norm(solved))
        own = float(np.linalg.norm(solved - finer))  # the solved column's own error
        gap = float(np.linalg.norm(guided - solved))
        assert gap <= max(2 * own, 1e-5 * scale), (case, key, gap / scale, own / scale)


def test_the_block_changes_nothing_outside_it_and_not_with_the_cache() -> None:
    inputs = sweep()
    model = model_for("air")
    stepped = moved(model, "compressibility.air_fraction", 1e-6)
    assert stepped is not None
    plain = stepped.force(inputs, A_BC, A_BT)
    runs = []
    for fresh in (False, True):
        kept = chamber._recent_run
        try:
            if fresh:  # nothing cached: the same guided numbers
                chamber._recent_run = Recent(chamber._run, size=0)
            with chamber.linearised():
                model.force(inputs, A_BC, A_BT)
                runs.append(stepped.force(inputs, A_BC, A_BT))
        finally:
            chamber._recent_run = kept
    assert np.array_equal(runs[0], runs[1])
    assert not np.array_equal(runs[0], plain)  # guided: not the solve's last digits
    np.testing.assert_array_equal(stepped.force(inputs, A_BC, A_BT), plain)
