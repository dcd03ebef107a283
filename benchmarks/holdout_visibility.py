"""Is each held-out effect visible in the raw data? (No diagnosis is run.)

For each case of bench_holdout.py (one seed), the sweep is simulated with the noise off
and its recorded force compared with the clean sweep's, test by test: the RMS force
difference over the whole test. The recording's force noise is 2 N RMS, so an effect is
visible when some tests differ by well over 2 N.

For the cavitation cases a second line compares with the same low charge and no vapour
floor (the oil may take tension): what the void itself does, the charge aside (the charge is
written in the manifest, so the lower gas force is no finding).

    .venv/bin/python benchmarks/holdout_visibility.py [--seed S] [--only PREFIX] [--jobs J]

Seed 0 (RMS force difference per test, N: min / median / max over the 15 tests; the force
noise is 2 N):

    comp_lo 1.4 / 18 / 110      comp_mid 2.7 / 31 / 148     comp_hi 10 / 95 / 259
    cav_lo (no void formed) 126 / 126 / 126: the charge only; vs no floor 0 / 0 / 0
    cav_mid 153 / 153 / 155; vs no floor 0 / 0 / 35 (void at click 2, 1 and 1.5 Hz)
    cav_hi 176 / 177 / 417; vs no floor 0 / 46 / 419
    fric_lo 11 / 12 / 14        fric_mid 19 / 20 / 22       fric_hi 19 / 23 / 31
    lag_lo 2.0 / 12 / 44        lag_mid 5.8 / 37 / 121      lag_hi 6.8 / 43 / 137
    thermal_lo 16 / 75 / 113    thermal_mid 20 / 97 / 145   thermal_hi 74 / 167 / 289
    contact_lo 16 / 16 / 16     contact_mid 61 / 61 / 61    contact_hi 336 / 337 / 338
    spec_gasvol 4.0 / 4.0 / 4.0 spec_charge 45 / 45 / 45    spec_preload 0 / 110 / 141
    pair_comp_fric 16 / 43 / 170           pair_lag_contact 164 / 177 / 220
    pair_thermal_fric 40 / 127 / 194       pair_cav_lag 159 / 160 / 186 (no floor: 0 / 0 / 63)
    triple_comp_fric_lag 18 / 90 / 236

Every effect is well above the noise in at least some tests; the weakest are the stiff-click
specific ones (comp_lo and lag_lo at clicks 15-20, 0.5 Hz: 1-2 N) and cav_mid, whose void
forms only on click 2 at 1-1.5 Hz.
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # bench_holdout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the plant: tests/holdout

import holdout.plant
from bench_holdout import CASES, Case, draw
from holdout.sweep import run_sweep


def forces(case: Case, seed: int, floor: bool = True) -> tuple[list[np.ndarray], list[str]]:
    """Recorded force per test (noise off); floor=False removes the vapour floor (a
    counterfactual: the oil may take tension) to isolate what cavitation itself does."""
    saved = holdout.plant.P_VAPOUR
    if not floor:
        holdout.plant.P_VAPOUR = -1e12
    try:
        truth, recs = run_sweep(draw(case, seed), "", seed=0, noise=False, write=False)
    finally:  # pool workers are reused
        holdout.plant.P_VAPOUR = saved
    return [r["force_N"] for r in recs], truth.physics()


def _rms(a: list[np.ndarray], b: list[np.ndarray]) -> list[float]:
    return [float(np.sqrt(np.mean((x - y) ** 2))) for x, y in zip(a, b, strict=True)]


def _line(label: str, d: list[float]) -> str:
    return (
        f"{label} {min(d):7.1f} / {float(np.median(d)):7.1f} / {max(d):7.1f}"
        f"   [{' '.join(f'{v:.0f}' for v in d)}]"
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", default="")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    cases = [c for c in CASES if c.name.startswith(a.only)]
    clean = next(c for c in CASES if c.name == "clean")
    with ProcessPoolExecutor(a.jobs) as pool:
        ref_fut = pool.submit(forces, clean, a.seed)
        futs = [
            (
                c,
                pool.submit(forces, c, a.seed),
                pool.submit(forces, c, a.seed, False) if "charge_pa" in c.ranges else None,
            )
            for c in cases
            if c.name != "clean"
        ]
        ref, _ = ref_fut.result()
        print(f"{'case':<22} {'truth':<40} RMS dF per test (N): min / median / max")
        for c, f, nofloor in futs:
            fs, phys = f.result()
            print(_line(f"{c.name:<22} {','.join(phys) or '-':<40}", _rms(fs, ref)), flush=True)
            if nofloor is not None:  # the cavitation itself, at the same (low) charge
                print(
                    _line(
                        f"{'':<22} {'  vs same charge, no vapour floor':<40}",
                        _rms(fs, nofloor.result()[0]),
                    ),
                    flush=True,
                )


if __name__ == "__main__":
    main()
