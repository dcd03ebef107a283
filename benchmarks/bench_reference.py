"""Benchmark of `diagnose` on the reference plant: physics it was not written with.

Run: .venv/bin/python benchmarks/bench_reference.py                 (2 seeds, ~40 sweeps)
     .venv/bin/python benchmarks/bench_reference.py --seeds 3 --first-seed 201
     ... --cache DIR   keep each sweep (a pickle named by its parameters and seed) and
                       read it back on a re-run, so only the diagnosis runs again
                       (empty it after changing the plant: the key is not its code),
                       and each DIAG.json beside it (CASE_sSEED.diag.json);
                       --reuse-verdicts scores those instead of diagnosing again
                       --sweep-only makes the sweeps and stops

Every recording is a click sweep of `simrig/reference.py` (clicks 2/5/10/15/20 x
0.5/1/1.5 Hz, 30 mm, 1 kHz, 1 warm-up + 3 measured cycles, 2 s rests, a body temperature
channel), made offline by `reference_sweep` (the stiff solver is slower than a sim-rig's
real time), diagnosed with the whole library and the default spec. The plant shares no
code with the term library: every effect reaches the diagnosis in a form that is not the
library's own (Wood's law in both chambers, a vapour state with finite rates, a LuGre
seal, laminar + turbulent bleeds whose viscosity follows a two-node thermal network, a
bump stop of exponent 2.3, a channel skew behind an anti-alias filter).

Truth is what the plant did, not what was asked: a low gas charge whose rebound chamber
never made vapour is a clean recording (a charge is calibration, not physics). Scored as
bench_diagnose: precision, recall, F1 per physics; the clean false-positive rate with its
Clopper-Pearson bound; E_t after / the clean recordings' mean E_t after, per recording;
and what the claimed terms report against the plant's own numbers. Seeds from
--first-seed (default 101: no rule was tuned on them).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import pickle
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

CLICKS = [2, 5, 10, 15, 20]
PHYSICS = ("compressibility", "cavitation", "friction", "sensor_lag", "thermal", "contact")
LIBRARY = (*PHYSICS, "gas_spring", "position_force")
THERMAL = {
    "viscosity_coeff_per_k": 0.03,
    "gas_thermal_coupling": 1.0,
    "bleed_land_m": 0.05,
    "start_temperature_c": 24.0,
}
STRENGTHS: dict[str, list[dict[str, float]]] = {
    "compressibility": [
        {"oil_bulk_modulus_pa": 1.6e9},
        {"oil_bulk_modulus_pa": 1.6e9, "air_fraction": 0.005},
        {"oil_bulk_modulus_pa": 1.6e9, "air_fraction": 0.02},
    ],
    "cavitation": [{"gas_pressure_factor": g} for g in (0.45, 0.4, 0.35)],
    "friction": [{"breakaway_n": b} for b in (15.0, 30.0, 60.0)],
    "sensor_lag": [{"force_skew_s": s} for s in (0.002, 0.004, 0.007)],
    "thermal": [{**THERMAL, "heating_factor": h} for h in (1.5, 3.0, 5.0)],
    "contact": [{"bump_onset_m": 0.021, "bump_force_at_10mm_n": f} for f in (100.0, 200.0, 400.0)],
}
SPEC_ERROR = {"gas_volume_factor": 1.4}  # calibration, not physics
# --fresh: strengths and pairs that no rule was looked at on (the cases above repeat the
# same plants on every seed, only the sensors' noise differs), set before any was run.
FRESH: list[tuple[str, tuple[str, ...], dict[str, float]]] = [
    ("fresh skew 3 ms", ("sensor_lag",), {"force_skew_s": 0.003}),
    ("fresh skew 5.5 ms", ("sensor_lag",), {"force_skew_s": 0.0055}),
    ("fresh oil 1.2 GPa", ("compressibility",), {"oil_bulk_modulus_pa": 1.2e9}),
    (
        "fresh air 0.25 %",
        ("compressibility",),
        {"oil_bulk_modulus_pa": 1.6e9, "air_fraction": 0.0025},
    ),
    ("fresh air 1 %", ("compressibility",), {"oil_bulk_modulus_pa": 1.6e9, "air_fraction": 0.01}),
    ("fresh heat 2x", ("thermal",), {**THERMAL, "heating_factor": 2.0}),
    ("fresh heat 4x", ("thermal",), {**THERMAL, "heating_factor": 4.0}),
    ("fresh charge 0.38", ("cavitation",), {"gas_pressure_factor": 0.38}),
    ("fresh breakaway 45 N", ("friction",), {"breakaway_n": 45.0}),
    ("fresh bump 24 mm", ("contact",), {"bump_onset_m": 0.024, "bump_force_at_10mm_n": 300.0}),
    ("fresh gas volume 0.7x", (), {"gas_volume_factor": 0.7}),
    (
        "fresh skew 3 ms + air 1 %",
        ("sensor_lag", "compressibility"),
        {"force_skew_s": 0.003, "oil_bulk_modulus_pa": 1.6e9, "air_fraction": 0.01},
    ),
]
PAIRS = (("friction", "compressibility"), ("sensor_lag", "cavitation"))
TRIPLE = ("friction", "compressibility", "thermal")
VAPOUR_M3 = 1e-8  # 10 mm³ of vapour: the plant cavitated


@dataclass
class Case:
    name: str
    asked: tuple[str, ...]
    seed: int
    params: dict[str, float]


@dataclass
class Row:
    case: Case
    truth: tuple[str, ...] = ()
    claimed: list[str] = field(default_factory=list)
    calibrated: list[str] = field(default_factory=list)
    e_before: float = math.nan
    e_after: float = math.nan
    sweep_s: float = math.nan
    diag_s: float = math.nan
    recovered: dict[str, tuple[float, float]] = field(default_factory=dict)
    error: str = ""
    reused: bool = False


def fresh_cases(seeds: list[int]) -> list[Case]:
    return [Case(f"{n} s{s}", asked, s, dict(p)) for n, asked, p in FRESH for s in seeds]


def make_cases(seeds: list[int]) -> list[Case]:
    cases = [Case(f"clean s{s}", (), s, {}) for s in seeds]
    cases += [Case(f"spec gas volume 1.4x s{s}", (), s, dict(SPEC_ERROR)) for s in seeds]
    for phys in PHYSICS:
        for lv, params in enumerate(STRENGTHS[phys]):
            for s in seeds:
                cases.append(Case(f"{phys}#{lv + 1} s{s}", (phys,), s, dict(params)))
    for group in (*PAIRS, TRIPLE):
        for s in seeds:
            params: dict[str, float] = {}
            for phys in group:
                params.update(STRENGTHS[phys][1])
            cases.append(Case(f"{'+'.join(group)} s{s}", tuple(group), s, params))
    return cases


def _plant_values(params: dict[str, float], charge_pa: float) -> dict[str, float]:
    from shockdyno.simrig.reference import PlantParams

    p = PlantParams(**params)
    p0 = charge_pa * p.gas_pressure_factor
    comp = (1 - p.air_fraction) / p.oil_bulk_modulus_pa + p.air_fraction / p0
    return {
        "beta_eff_mpa": 1e-6 / comp,
        "release_kpa": p.release_pressure_pa / 1e3,
        "breakaway_n": p.breakaway_n,
        "delay_ms": 1e3 * p.force_skew_s,
        "bump_onset_mm": 1e3 * p.bump_onset_m,
    }


def _reported(d: dict[str, Any], charge_pa: float) -> dict[str, float]:
    out: dict[str, float] = {}
    for f in d["findings"]:
        if not f.get("claimed"):
            continue
        v = {k: (p.get("value") if isinstance(p, dict) else p) for k, p in f["parameters"].items()}
        phys = f["physics"]
        if phys == "compressibility":
            a, c = v.get("air_fraction", 0.0), v.get("oil_compressibility_per_gpa", 0.0) * 1e-9
            comp = (1 - a) * c + a / charge_pa
            out["beta_eff_mpa"] = 1e-6 / comp if comp > 0 else math.inf
        elif phys == "cavitation":
            out["release_kpa"] = v.get("release_pressure_pa", math.nan) / 1e3
        elif phys == "friction":
            out["breakaway_n"] = v.get("breakaway_n", math.nan)
        elif phys == "sensor_lag":
            out["delay_ms"] = 1e3 * (v.get("delay_s", 0.0) + v.get("load_cell_lag_s", 0.0))
        elif phys == "contact":
            out["bump_onset_mm"] = 1e3 * v.get("bump_onset_m", math.nan)
    return out


def _cache_path(case: Case) -> Path | None:
    """Where --cache keeps a sweep: a re-run diagnoses the same recordings without
    integrating them again. A sweep depends on its plant parameters and seed, and on the
    plant's code, which the key does not hold."""
    cache_dir = os.environ.get("BENCH_REFERENCE_CACHE", "")
    if not cache_dir:
        return None
    key = json.dumps([case.seed, sorted(case.params.items()), CLICKS], default=str)
    digest = hashlib.sha256(key.encode()).hexdigest()[:16]
    return Path(cache_dir) / f"{digest}.pkl"


def run_case(case: Case) -> Row:
    row = Row(case)
    try:
        from shockdyno.diagnose.engine import diagnose
        from shockdyno.diagnose.verdict import to_json
        from shockdyno.model.spec import load_spec
        from shockdyno.simrig.reference import PlantParams, reference_sweep

        spec = load_spec()
        t0 = time.perf_counter()
        cached = _cache_path(case)
        if cached is not None and cached.exists():
            with cached.open("rb") as fh:
                tests, truth = pickle.load(fh)
        else:
            tests, truth = reference_sweep(spec, PlantParams(**case.params), CLICKS, seed=case.seed)
            if cached is not None:
                tmp = cached.with_suffix(".tmp")
                with tmp.open("wb") as fh:
                    pickle.dump((tests, truth), fh)
                tmp.replace(cached)
        row.sweep_s = time.perf_counter() - t0
        if os.environ.get("BENCH_REFERENCE_SWEEP_ONLY"):
            return row
        real = set(case.asked)
        if "cavitation" in real and truth.max_vapour_m3 < VAPOUR_M3:
            real.discard("cavitation")  # the chamber never made vapour: nothing to find
        row.truth = tuple(sorted(real))
        t1 = time.perf_counter()
        out = None
        if cached is not None:  # the verdict beside its sweep, to read again
            out = cached.with_name(f"{case.name.replace(' ', '_').replace('+', '-')}.diag.json")
        if out is not None and out.exists() and os.environ.get("BENCH_REFERENCE_REUSE"):
            d = json.loads(out.read_text())
            row.reused = True
        else:
            d = to_json(diagnose(tests))
            if out is not None:
                out.write_text(json.dumps(d, default=str))
        row.diag_s = time.perf_counter() - t1
        row.claimed = list(d["verdict"]["physics"])
        row.calibrated = [
            c["parameter"] for c in d["verdict"].get("calibration", []) if c.get("moved")
        ]
        row.e_before = float(np.mean([t["E_t_before"] for t in d["tests"]]))
        row.e_after = float(np.mean([t["E_t_after"] for t in d["tests"]]))
        plant = _plant_values(case.params, spec.gas_pressure_pa)
        for key, got in _reported(d, spec.gas_pressure_pa).items():
            row.recovered[key] = (plant[key], got)
    except Exception as exc:  # a failed case is a row of the table, not the end of the run
        last = traceback.format_exc().strip().splitlines()[-1:]
        row.error = f"{type(exc).__name__}: {exc}"[:160] or " | ".join(last)
    return row


def fp_upper(k: int, n: int, level: float = 0.95) -> float:
    if n == 0:
        return math.nan
    if k >= n:
        return 1.0
    from scipy.stats import beta

    return float(beta.ppf(level, k + 1, n - k))


def fmt(x: float, spec: str = ".2f") -> str:
    return "  —  " if not math.isfinite(x) else format(x, spec)


def summary(rows: list[Row]) -> None:
    ok = [r for r in rows if not r.error]
    clean = [r for r in ok if not r.truth]
    clean_e = float(np.mean([r.e_after for r in clean])) if clean else math.nan
    print(f"\nconfusion matrix: {len(ok)} recordings scored, {len(rows) - len(ok)} failed")
    print(f"    {'physics':16s} P     R     F1    (tp fp fn)   E_t before -> after")
    f1s = []
    for p in LIBRARY:
        tp = sum(p in r.truth and p in r.claimed for r in ok)
        fp = sum(p not in r.truth and p in r.claimed for r in ok)
        fn = sum(p in r.truth and p not in r.claimed for r in ok)
        prec = tp / (tp + fp) if tp + fp else math.nan
        rec = tp / (tp + fn) if tp + fn else math.nan
        f1 = 2 * tp / (2 * tp + fp + fn) if tp + fp + fn else math.nan
        if p in PHYSICS:
            f1s.append(f1)
        mine = [r for r in ok if p in r.truth]
        eb = float(np.mean([r.e_before for r in mine])) if mine else math.nan
        ea = float(np.mean([r.e_after for r in mine])) if mine else math.nan
        print(
            f"    {p:16s} {fmt(prec)}  {fmt(rec)}  {fmt(f1)}  ({tp:2d} {fp:2d} {fn:2d})   "
            f"{fmt(eb, '.4f')} -> {fmt(ea, '.4f')}"
        )
    k = sum(bool(r.claimed) for r in clean)
    print(
        f"    clean (incl. spec errors, cavitation asked but no vapour): {k} of {len(clean)} "
        f"with a claim, rate {fmt(k / len(clean) if clean else math.nan)}, 95 % upper bound "
        f"{fmt(fp_upper(k, len(clean)))} (Clopper-Pearson); mean E_t after {fmt(clean_e, '.4f')}"
    )
    ratios = [r.e_after / clean_e for r in ok if r.truth]
    within = sum(x <= 1.5 for x in ratios)
    print(
        f"    E_t after <= 1.5x clean on {within} of {len(ratios)} effect recordings "
        f"({fmt(within / len(ratios) if ratios else math.nan)}); min F1 {fmt(min(f1s))}"
    )
    print("\nparameter recovery (claimed terms against the plant's numbers):")
    for key in ("beta_eff_mpa", "release_kpa", "breakaway_n", "delay_ms", "bump_onset_mm"):
        pairs = [(r.case.name, *r.recovered[key]) for r in ok if key in r.recovered]
        for name, want, got in pairs:
            rel = (got - want) / want if want and math.isfinite(want) else math.nan
            print(
                f"    {key:14s} {name:40s} plant {want:10.4g}  reported {got:10.4g}  "
                f"({fmt(rel, '+.0%')})"
            )


def print_row(r: Row) -> None:
    c = r.case
    if r.error:
        print(f"  {c.name:40s} FAILED: {r.error}", flush=True)
        return
    print(
        f"  {c.name:40s} truth {'+'.join(r.truth) or 'clean':34s} claimed "
        f"{','.join(r.claimed) or '-':34s} calibrated {','.join(r.calibrated) or '-':30s} "
        f"E_t {r.e_before:.4f}->{r.e_after:.4f}  sweep {r.sweep_s:4.0f} s "
        + ("diag reused" if r.reused else f"diag {r.diag_s:4.0f} s"),
        flush=True,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2, help="seeds per case (default 2)")
    ap.add_argument("--first-seed", type=int, default=101)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", help="comma-separated case-name prefixes")
    ap.add_argument("--cache", help="keep each sweep here and read it back on a re-run")
    ap.add_argument("--fresh", action="store_true", help="the FRESH cases instead")
    ap.add_argument("--sweep-only", action="store_true", help="make (and cache) the sweeps")
    ap.add_argument(
        "--reuse-verdicts",
        action="store_true",
        help="with --cache: score a DIAG.json already beside its sweep instead of diagnosing "
        "again (only when the diagnosis code has not changed since it was written)",
    )
    args = ap.parse_args()
    if args.seeds < 1 or args.jobs < 1:
        ap.error("--seeds and --jobs: at least 1")
    if args.cache and Path(args.cache).exists() and not Path(args.cache).is_dir():
        ap.error(f"--cache {args.cache}: not a directory")
    if args.cache:  # read by run_case in the pool's processes, which inherit the environment
        Path(args.cache).mkdir(parents=True, exist_ok=True)
        os.environ["BENCH_REFERENCE_CACHE"] = args.cache
    if args.reuse_verdicts:
        if not args.cache:
            ap.error("--reuse-verdicts needs --cache")
        os.environ["BENCH_REFERENCE_REUSE"] = "1"
    if args.sweep_only:
        os.environ["BENCH_REFERENCE_SWEEP_ONLY"] = "1"
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    cases = fresh_cases(seeds) if args.fresh else make_cases(seeds)
    if args.only:
        cases = [c for c in cases if c.name.startswith(tuple(args.only.split(",")))]
        if not cases:
            ap.error(f"--only {args.only}: no case's name starts with that")
    print(
        f"{len(cases)} reference-plant sweeps, seeds {seeds}, {args.jobs} in parallel; clicks "
        f"{CLICKS} x 0.5/1/1.5 Hz; cpus {os.cpu_count()}, load {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    t0 = time.perf_counter()
    rows: list[Row] = []
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        # The longest first (more effects, air: more rounds, a chamber to integrate), so
        # the last minutes do not run one long case beside an idle core; the order is
        # the submission's only, each case's result is its own.
        longest = sorted(cases, key=lambda c: (-len(c.asked), "compressibility" not in c.asked))
        futures = {pool.submit(run_case, c): c for c in longest}
        for fut in as_completed(futures):
            row = fut.result()
            rows.append(row)
            print_row(row)
    order = {c.name: i for i, c in enumerate(cases)}
    rows.sort(key=lambda r: order[r.case.name])
    print(f"\nper recording ({time.perf_counter() - t0:.0f} s in all):")
    for r in rows:
        print_row(r)
    summary(rows)
    sys.stdout.flush()


if __name__ == "__main__":
    main()
