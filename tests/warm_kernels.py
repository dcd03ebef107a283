"""Compile the numba kernels into their on-disk cache once, before the test workers start.

`make test` runs this beside mypy: on a fresh clone each pytest worker would otherwise
compile the same kernels (the model's chamber, flow, seal and filters; the reference
plant's) at its first diagnosis, each on its own. A short diagnosis of a reference-plant
sweep with a compressible oil runs them (its candidates include the seal and the lags).
"""

from __future__ import annotations

from shockdyno.diagnose.engine import diagnose
from shockdyno.model import load_spec
from shockdyno.simrig.reference import PlantParams, reference_sweep


def main() -> None:
    spec = load_spec()
    tests = reference_sweep(spec, PlantParams(air_fraction=0.01), [2], (1.5,), seed=1)[0]
    diagnose(tests)


if __name__ == "__main__":
    main()
