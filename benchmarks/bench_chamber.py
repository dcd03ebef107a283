"""The chamber kernel (model/chamber.py) against an earlier revision of itself, in one run.

Run: .venv/bin/python benchmarks/bench_chamber.py [--baseline REV] [--reps N] [--compile-runs N]

The baseline is model/chamber.py as it was at REV (default f4c5eca: the kernels of 23-31
scalars, before issue 48 put the chamber's constants in one record and split `_step` and
`_run`), read with `git show` into a temporary folder and imported beside the current one.
For each case, the chamber integrations a model evaluation makes (their inputs captured
from the model itself) are run by both kernels, interleaved, with the result cache off
(`_recent_run` holding nothing, so every call integrates):

- bit identity: every output of every call (Δp, vapour, p_c, final state) array_equal;
- per-call time: the least of N interleaved repetitions of each call, summed over the
  case's calls (CPU time: the machine is shared), and its ratio to the baseline's;
- first compile: a fresh process with an empty numba cache (NUMBA_CACHE_DIR in a
  temporary folder) imports the kernel and makes the first case's calls (what CI pays
  on a clean clone), then a second process on the same cache does the same and must load
  every kernel from it (no compilation: numba's cache misses 0).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import pickle
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from shockdyno.model import DamperModel, ModelInputs, load_spec
from shockdyno.model import chamber as current
from shockdyno.model.recent import Recent
from shockdyno.model.terms import compressibility, make_term

REPO = Path(__file__).resolve().parents[1]
SPEC = load_spec()
LOW_CHARGE = SPEC.with_values({"gas_pressure_pa": 5.0e5})
A_BC, A_BT = 2e-6, 1e-6
NEW = "  (gas: not in the baseline)"
CASES: dict[str, tuple[dict[str, float], Any, float, bool]] = {
    # name: (term values, spec, sample step s, guided: a Jacobian column in `linearised`)
    "air 1%, 1 kHz": ({"compressibility.air_fraction": 0.01}, SPEC, 1e-3, False),
    "air 1%, guided column": ({"compressibility.air_fraction": 0.01}, SPEC, 1e-3, True),
    "air + oil, 5 ms": (
        {"compressibility.air_fraction": 0.02, "compressibility.oil_compressibility_per_gpa": 0.7},
        SPEC,
        5e-3,
        False,
    ),
    "air + vapour, 1 kHz": (
        {"compressibility.air_fraction": 0.005, "cavitation.release_pressure_pa": 3.0e5},
        SPEC.with_values({"gas_pressure_pa": 6.0e5}),
        1e-3,
        False,
    ),
    "cavitation with rates": (
        {
            "cavitation.release_pressure_pa": 4.0e5,
            "cavitation.form_kpa_s_per_cm3": 50.0,
            "cavitation.condense_kpa_s_per_cm3": 200.0,
        },
        LOW_CHARGE,
        1e-3,
        False,
    ),
    # The released gas (issue 44): the baseline has no such state, so this case's outputs
    # differ from it by design; its time is what the gas costs where a sweep boils.
    "vapour + released gas": (
        {
            "cavitation.release_pressure_pa": 8.0e4,
            "cavitation.gas_release_cm3_s": 3.0,
        },
        LOW_CHARGE,
        1e-3,
        False,
    ),
    "thermal + air": (
        {"thermal.damping_coeff_per_k": 0.004, "compressibility.air_fraction": 0.01},
        SPEC,
        1e-3,
        False,
    ),
}


def sweep(dt: float) -> ModelInputs:
    """Three periodic tests of two cycles, 30 mm at 0.5, 1 and 1.5 Hz, warming 10 K."""
    parts = []
    for f in (0.5, 1.0, 1.5):
        t = np.arange(int(2.0 / f / dt)) * dt
        w = 2 * np.pi * f
        x = 0.03 * np.sin(w * t)
        one = ModelInputs.single(x, 0.03 * w * np.cos(w * t), -w * w * x, dt, 40.0 + 5 * t)
        parts.append(replace(one, periodic=True))
    return ModelInputs.stack(parts)


def captured(name: str) -> list[tuple[tuple[Any, ...], dict[str, Any]]]:
    """The arguments of each chamber integration the case's model makes (the guided case:
    the column's, after its guide)."""
    values, spec, dt, guided = CASES[name]
    model = DamperModel(
        spec, tuple(make_term(t) for t in dict.fromkeys(k.split(".")[0] for k in values)), values
    )
    inputs = sweep(dt)
    calls: list[tuple[tuple[Any, ...], dict[str, Any]]] = []

    def record(*args: Any, **kw: Any) -> Any:
        calls.append((args, kw))
        return current.integrate(*args, **kw)

    kept = compressibility.integrate
    compressibility.integrate = record
    try:
        if guided:
            key = next(iter(values))
            moved = model.with_values({key: model.value(key) * (1 + 1e-6)})
            model.force(inputs, A_BC, A_BT)
            calls.clear()
            moved.force(inputs, A_BC, A_BT)
        else:
            model.force(inputs, A_BC, A_BT)
    finally:
        compressibility.integrate = kept
    return calls


def baseline(rev: str, folder: Path) -> ModuleType:
    text = subprocess.run(
        ["git", "-C", str(REPO), "show", f"{rev}:src/shockdyno/model/chamber.py"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    path = folder / "chamber_baseline.py"
    path.write_text(text)
    return load(path)


def load(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module
    spec.loader.exec_module(module)
    return module


def run(module: ModuleType, call: tuple[tuple[Any, ...], dict[str, Any]], guide: Any) -> Any:
    args, kw = call
    if guide is None:
        return module.integrate(*args, **kw)
    with module.linearised() as guides:  # the column's guide, as the first integration left it
        guides.update(guide)
        return module.integrate(*args, **kw)


def guide_of(module: ModuleType, name: str) -> Any:
    """The guides the case's first integrations leave (None: not a guided case)."""
    values, spec, dt, guided = CASES[name]
    if not guided:
        return None
    model = DamperModel(
        spec, tuple(make_term(t) for t in dict.fromkeys(k.split(".")[0] for k in values)), values
    )
    kept = compressibility.integrate

    def integrate(*args: Any, **kw: Any) -> Any:  # the baseline returns no released gas
        out = module.integrate(*args, **kw)
        return out if len(out) == 5 else (*out, np.zeros_like(out[0]))

    compressibility.integrate = integrate
    try:
        with module.linearised() as guides:
            model.force(sweep(dt), A_BC, A_BT)
            return dict(guides)
    finally:
        compressibility.integrate = kept


def timed(module: ModuleType, calls: list[Any], guide: Any) -> tuple[float, list[Any]]:
    t0 = time.process_time()  # CPU time: the machine is shared, and wall time is its load's
    out = [run(module, c, guide) for c in calls]
    return time.process_time() - t0, out


def first_compile(path: Path | None, cache: Path) -> dict[str, Any]:
    """A fresh process importing the kernel (at `path`; None: this tree's) and making the
    first case's calls on the numba cache in `cache`: seconds for the first calls and for
    the same calls again (nothing to compile), and numba's cache stats of `_run`."""
    if path is None:
        load_it = "from shockdyno.model import chamber as m"
    else:
        load_it = f"""import importlib.util
spec = importlib.util.spec_from_file_location({path.stem!r}, {str(path)!r})
m = importlib.util.module_from_spec(spec)
sys.modules[{path.stem!r}] = m
spec.loader.exec_module(m)"""
    code = f"""import json, pickle, sys, time
from shockdyno.model.recent import Recent
{load_it}
m._recent_run = Recent(m._run, size=0)
with open({str(cache / "calls.pkl")!r}, "rb") as f:
    calls = pickle.load(f)
took, wall = [], []
for _ in range(2):
    t0, w0 = time.process_time(), time.perf_counter()
    for args, kw in calls:
        m.integrate(*args, **kw)
    took.append(time.process_time() - t0)
    wall.append(time.perf_counter() - w0)
stats = m._run.stats
print(json.dumps({{"first_s": took[0], "again_s": took[1], "first_wall_s": wall[0],
                  "hits": sum(stats.cache_hits.values()),
                  "misses": sum(stats.cache_misses.values())}}))
"""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache / "numba"))
    got = subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True, text=True, env=env
    )
    return dict(json.loads(got.stdout.strip().splitlines()[-1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--baseline", default="f4c5eca", help="git revision of the baseline")
    parser.add_argument("--reps", type=int, default=7, help="interleaved repetitions per call")
    parser.add_argument(
        "--compile-runs", type=int, default=1, help="first compilations of each kernel, in turn"
    )
    opts = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        old = baseline(opts.baseline, folder)
        for module in (old, current):  # every call integrates
            module._recent_run = Recent(module._run, size=0)  # type: ignore[attr-defined]
        print(f"chamber kernel: this tree vs {opts.baseline} (same process, interleaved)")
        print(f"per-call CPU time, the least of {opts.reps} repetitions")
        print(f"{'case':26s} {'calls':>5s} {'samples':>8s} {'now ms':>9s} {'base ms':>9s}")
        total_now = total_old = 0.0
        identical = True
        for name in CASES:
            calls = captured(name)
            g_now, g_old = guide_of(current, name), guide_of(old, name)
            best_now = best_old = math.inf
            for _ in range(opts.reps):
                t_old, out_old = timed(old, calls, g_old)
                t_now, out_now = timed(current, calls, g_now)
                best_now, best_old = min(best_now, t_now), min(best_old, t_old)
            # (Δp, vapour, p_c, state): the state's first five (the baseline carries no gas;
            # the released gas, the sixth and seventh, and its output are new).
            same = all(
                np.array_equal(a[: b.size], b, equal_nan=True)
                for r_now, r_old in zip(out_now, out_old, strict=True)
                for a, b in zip(r_now[: len(r_old)], r_old[: len(r_now)], strict=True)
            )
            with_gas = name == "vapour + released gas"
            identical &= same or with_gas
            total_now += best_now
            total_old += best_old
            samples = sum(c[0][2].size for c in calls)
            print(
                f"{name:26s} {len(calls):5d} {samples:8d} {best_now * 1e3:9.2f} "
                f"{best_old * 1e3:9.2f}  ratio {best_now / best_old:5.3f}"
                f"{'' if same else NEW if with_gas else '  NOT bit-identical'}"
            )
        print(
            f"{'all':26s} {'':5s} {'':8s} {total_now * 1e3:9.2f} {total_old * 1e3:9.2f}"
            f"  ratio {total_now / total_old:5.3f} (time now / baseline; < 1: faster)"
        )
        print(
            "bit identity (every output of every call, but the released-gas case's): "
            f"{'yes' if identical else 'NO'}"
        )
        compile_report(folder, old, opts.compile_runs)


def compile_report(folder: Path, old: ModuleType, runs: int) -> None:
    """The first compilation of each kernel, `runs` times in turn, each on an empty cache
    and then again from it in a second process."""
    calls = captured("air + vapour, 1 kHz")
    with open(folder / "calls.pkl", "wb") as f:
        pickle.dump(calls, f)
    for run_no in range(runs):
        for label, path in (("now", None), ("baseline", Path(old.__file__ or ""))):
            cache = folder / f"cache-{label}-{run_no}"
            cache.mkdir()
            (cache / "calls.pkl").write_bytes((folder / "calls.pkl").read_bytes())
            cold = first_compile(path, cache)
            warm = first_compile(path, cache)
            print(
                f"first calls, {label:8s}: empty numba cache {cold['first_s']:6.2f} s CPU "
                f"({cold['first_wall_s']:.2f} s wall; again {cold['again_s']:.3f} s; _run's "
                f"cache misses {cold['misses']}, hits {cold['hits']}); second process "
                f"{warm['first_s']:.3f} s (again {warm['again_s']:.3f} s; misses "
                f"{warm['misses']}, hits {warm['hits']})"
            )


if __name__ == "__main__":
    main()
