"""Benchmark of `diagnose` on plants written apart from the library: physics in other forms.

Run: .venv/bin/python benchmarks/bench_reference.py                 (2 seeds, 46 sweeps)
     .venv/bin/python benchmarks/bench_reference.py --plant holdout --seeds 1
     .venv/bin/python benchmarks/bench_reference.py --seeds 3 --first-seed 760
     ... --cache DIR   keep each sweep (reference: a pickle named by its parameters and
                       seed; holdout: its CSV files and REC.mcap) and read it back on a
                       re-run, so only the diagnosis runs again (empty it after changing
                       a plant: the key is not its code), and each DIAG.json beside it
                       (CASE_sSEED.diag.json); --reuse-verdicts scores those instead of
                       diagnosing again; --sweep-only makes the sweeps and stops

Two plants (`--plant`):
- reference (`simrig/reference.py`): every equation other than the library's (Tait oil
  with air carried in it, a bubble population under a release pressure, flow-number
  orifices of a tapered needle's annulus, a wedge-beam shim stack that opens and closes
  in time, an elasto-plastic seal with a Hess-Soom level, Walther viscosity, a Maxwell
  bump rubber, a load cell's resonance behind a Bessel anti-alias and a skewed channel:
  the table is in docs/diagnose-method.md). Click sweeps (clicks 2/5/10/15/20 x 0.5/1/1.5 Hz,
  30 mm, 1 kHz, 1 warm-up + 3 measured cycles, 2 s rests, the body's temperature), made
  offline by `reference_sweep`. Each physics at three strengths, two pairs and a triple,
  clean and a spec error (the gas volume 1.4x). Seeds from 755 (fresh: no rule was
  tuned on them; a seed changes the sensors' noise, not the plant).
- holdout (`tests/holdout/plant.py`, written by someone who had not read the project's
  physics): bench_holdout.py's cases (each physics lo/mid/hi, spec errors, pairs, a
  triple; a seed draws every strength anew and the noise), its own sweep (clicks
  2/5/10/15/20, 4 measured cycles) written as CSV files and imported as `shockdyno
  import` does. Seeds from 3 (fresh).
Both diagnosed with the whole library and the default spec.

Truth is what the plant did, not what was asked: a low gas charge whose rebound chamber
never made vapour is a clean recording (a charge is calibration, not physics). Scored:
precision, recall, F1 per physics; the clean false-positive rate with its one-sided 95 %
Clopper-Pearson bound; E_t after / the clean recordings' mean E_t after, per recording;
and what the claimed terms report against the plant's own numbers (β_eff at the charge,
the breakaway, the force channel's low-frequency delay, the bump's onset, the release
pressure). The breakaway is the seal's static force as the recording shows it: the largest
seal force at a reversal, Coulomb included, the reported one (the finding's
`breakaway_reached_n`) against the plant's own seal on the same sweep. Neither plant's seal
reaches its static level F_s (its force at rest) on these tests: a reversing rod is past
the Stribeck speed before the seal has turned, so F_s is printed beside it, not compared.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import pickle
import resource
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

CLICKS = [2, 5, 10, 15, 20]
PLANTS = ("reference", "holdout")
FIRST_SEED = {"reference": 755, "holdout": 3}  # fresh: no rule was tuned on these or later
PHYSICS = ("compressibility", "cavitation", "friction", "sensor_lag", "thermal", "contact")
LIBRARY = (*PHYSICS, "gas_spring", "position_force")
# The reference plant's effects in its own parameters (simrig/reference.py PlantParams).
THERMAL = {
    "viscosity_at_100c_cst": 3.0,  # Walther through the spec's 11 cSt at 40 °C
    "gas_thermal_coupling": 1.0,
    "start_temperature_c": 24.0,
}
STRENGTHS: dict[str, list[dict[str, float]]] = {
    "compressibility": [
        {"oil_bulk_modulus_pa": 1.6e9},
        {"oil_bulk_modulus_pa": 1.6e9, "air_fraction": 0.005},
        {"oil_bulk_modulus_pa": 1.6e9, "air_fraction": 0.02},
    ],
    # The rewritten plant's rebound chamber reaches 3 kPa only below ~0.38 of the charge
    # (0.45 and 0.40 made none on clicks 2/10/20, seed 0, noise off).
    "cavitation": [{"gas_pressure_factor": g} for g in (0.37, 0.33, 0.3)],
    "friction": [{"breakaway_n": b} for b in (15.0, 30.0, 60.0)],
    "sensor_lag": [{"force_skew_s": s} for s in (0.002, 0.004, 0.007)],
    "thermal": [{**THERMAL, "heating_factor": h} for h in (1.5, 3.0, 5.0)],
    "contact": [{"bump_onset_m": 0.021, "bump_force_at_10mm_n": f} for f in (100.0, 200.0, 400.0)],
}
SPEC_ERROR = {"gas_volume_factor": 1.4}  # calibration, not physics
# --fresh: strengths and pairs other than the cases above (which repeat the same plants on
# every seed, only the sensors' noise differs), set before any was run.
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
    ("fresh charge 0.35", ("cavitation",), {"gas_pressure_factor": 0.35}),
    ("fresh breakaway 45 N", ("friction",), {"breakaway_n": 45.0}),
    ("fresh lip drag 30 N", ("friction",), {"lip_drag_n": 30.0}),
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
    params: dict[str, float]  # the reference plant's; the holdout case draws its own
    plant: str = "reference"
    holdout: str = ""  # bench_holdout.py's case name


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
    diag_cpu_s: float = math.nan  # user + sys of this process and its children
    recovered: dict[str, tuple[float, float]] = field(default_factory=dict)
    static_n: float = math.nan  # the plant seal's static level, beside its breakaway reached
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


def holdout_cases(seeds: list[int]) -> list[Case]:
    """bench_holdout.py's cases; what each asks is known only once its plant has run."""
    from bench_holdout import CASES

    return [Case(f"{c.name} s{s}", (), s, {}, "holdout", c.name) for c in CASES for s in seeds]


def _plant_values(params: dict[str, float], charge_pa: float, truth: Any) -> dict[str, float]:
    from shockdyno.model.spec import load_spec
    from shockdyno.simrig.reference import PlantParams, ReferencePlant

    p = PlantParams(**params)
    plant = ReferencePlant(load_spec(), p, 1000.0)
    cell_s = 2 * p.load_cell_damping / (2 * math.pi * p.load_cell_hz)
    return {
        "beta_eff_mpa": plant.bulk_modulus_pa(charge_pa * p.gas_pressure_factor) / 1e6,
        "release_kpa": p.release_pressure_pa / 1e3,
        # the seal's force reached on the sweep, and its static level F_c + F_b
        "breakaway_n": getattr(truth, "seal_peak_n", math.nan),
        "breakaway_static_n": plant.spec.friction_n + p.breakaway_n,
        "delay_ms": 1e3 * (p.force_skew_s + cell_s),
        "bump_onset_mm": 1e3 * p.bump_onset_m,
    }


def _holdout_values(truth: Any) -> dict[str, float]:
    from holdout.plant import P_VAPOUR

    v = truth.values
    out = {"release_kpa": v.get("release_pressure_pa", P_VAPOUR) / 1e3}
    if "bulk_modulus_at_charge_pa" in v:
        out["beta_eff_mpa"] = v["bulk_modulus_at_charge_pa"] / 1e6
    if "breakaway_n" in v:  # the lip's force reached on the sweep; its static level F_s
        out["breakaway_n"] = max(getattr(t, "max_lip_n", math.nan) for t in truth.tests)
        out["breakaway_static_n"] = v["breakaway_n"]
    if "force_delay_s" in v:
        out["delay_ms"] = 1e3 * v["force_delay_s"]
    if "bump_onset_m" in v:
        out["bump_onset_mm"] = 1e3 * v["bump_onset_m"]
    if v.get("topout_onset_m") is not None:  # below mid-stroke, whichever sign it is kept in
        out["topout_onset_mm"] = -1e3 * abs(v["topout_onset_m"])
    return out


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
        elif phys == "friction":  # the seal's force reached, not the law's level F_b
            out["breakaway_n"] = v.get("breakaway_reached_n", math.nan)
        elif phys == "sensor_lag":
            out["delay_ms"] = 1e3 * (v.get("delay_s", 0.0) + v.get("load_cell_lag_s", 0.0))
        elif phys == "contact":
            out["bump_onset_mm"] = 1e3 * v.get("bump_onset_m", math.nan)
            if v.get("topout_force_n", 0.0) > 0:
                out["topout_onset_mm"] = 1e3 * v.get("topout_onset_m", math.nan)
    return out


def _cache_path(case: Case) -> Path | None:
    """Where --cache keeps a sweep: a re-run diagnoses the same recordings without
    making them again. A sweep depends on its plant, parameters and seed, and on the
    plant's code, which the key does not hold."""
    cache_dir = os.environ.get("BENCH_REFERENCE_CACHE", "")
    if not cache_dir:
        return None
    key = json.dumps(
        [case.plant, case.holdout, case.seed, sorted(case.params.items()), CLICKS], default=str
    )
    digest = hashlib.sha256(key.encode()).hexdigest()[:16]
    return Path(cache_dir) / (f"{digest}.pkl" if case.plant == "reference" else digest)


def _reference_sweep(case: Case, spec: Any, cached: Path | None) -> tuple[Any, set[str], Any]:
    """(tests, what the plant did, its values) of a reference-plant case."""
    from shockdyno.simrig.reference import PlantParams, reference_sweep

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
    real = set(case.asked)
    if "cavitation" in real and truth.max_vapour_m3 < VAPOUR_M3:
        real.discard("cavitation")  # the chamber never made vapour: nothing to find
    return tests, real, _plant_values(case.params, spec.gas_pressure_pa, truth)


def _holdout_sweep(case: Case, where: Path) -> tuple[Path, set[str], dict[str, float]]:
    """(its recording, what the plant did, its values) of a held-out case, whose CSV
    files and REC.mcap are kept in `where` (reused when there)."""
    from bench_holdout import CASES, draw, noise_seed
    from holdout.recording import holdout_recording
    from holdout.sweep import SweepTruth

    (c,) = [c for c in CASES if c.name == case.holdout]
    rec, truth_file = where / "REC.mcap", where / "truth.pkl"
    if rec.exists() and truth_file.exists():
        with truth_file.open("rb") as fh:
            truth: SweepTruth = pickle.load(fh)
    else:
        where.mkdir(parents=True, exist_ok=True)
        rec, truth = holdout_recording(draw(c, case.seed), where, noise_seed(c, case.seed))
        with truth_file.open("wb") as fh:
            pickle.dump(truth, fh)
    return rec, set(truth.physics()), _holdout_values(truth)


def _cpu_s() -> float:
    """User + system CPU of this process and its waited-for children: wall time is the
    machine's load, CPU is what the diagnosis costs."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def run_case(case: Case) -> Row:
    row = Row(case)
    try:
        import tempfile

        from shockdyno import schema
        from shockdyno.diagnose.engine import diagnose
        from shockdyno.diagnose.file import diagnose_file
        from shockdyno.diagnose.verdict import to_json
        from shockdyno.model.spec import load_spec

        spec = load_spec()
        t0 = time.perf_counter()
        cached = _cache_path(case)
        scratch = None
        if case.plant == "reference":
            tests, real, plant = _reference_sweep(case, spec, cached)
        else:
            if cached is None:
                scratch = tempfile.TemporaryDirectory(prefix="bench-holdout-")
            where = cached if cached is not None else Path(scratch.name)  # type: ignore[union-attr]
            rec, real, plant = _holdout_sweep(case, where)
        row.sweep_s = time.perf_counter() - t0
        if os.environ.get("BENCH_REFERENCE_SWEEP_ONLY"):
            return row
        row.truth = tuple(sorted(real))
        t1, cpu1 = time.perf_counter(), _cpu_s()
        out = None
        if cached is not None:  # the verdict beside its sweep, to read again
            name = f"{case.plant}_{case.name.replace(' ', '_').replace('+', '-')}.diag.json"
            out = cached.parent / name
        if out is not None and out.exists() and os.environ.get("BENCH_REFERENCE_REUSE"):
            d = json.loads(out.read_text())
            row.reused = True
        else:
            if case.plant == "reference":
                d = to_json(diagnose(tests))
            else:  # the document as DIAG.json holds it
                d = schema.to_json(diagnose_file(rec)[1])
            if out is not None:
                out.write_text(json.dumps(d, default=str))
        if scratch is not None:
            scratch.cleanup()
        row.diag_s = time.perf_counter() - t1
        row.diag_cpu_s = math.nan if row.reused else _cpu_s() - cpu1
        row.claimed = list(d["verdict"]["physics"])
        row.calibrated = [
            c["parameter"] for c in d["verdict"].get("calibration", []) if c.get("moved")
        ]
        row.e_before = float(np.mean([t["E_t_before"] for t in d["tests"]]))
        row.e_after = float(np.mean([t["E_t_after"] for t in d["tests"]]))
        for key, got in _reported(d, spec.gas_pressure_pa).items():
            if key in plant:
                row.recovered[key] = (plant[key], got)
        if "breakaway_n" in row.recovered:
            row.static_n = plant.get("breakaway_static_n", math.nan)
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
    keys = ("beta_eff_mpa", "release_kpa", "breakaway_n", "delay_ms", "bump_onset_mm")
    for key in (*keys, "topout_onset_mm"):
        pairs = [(r, *r.recovered[key]) for r in ok if key in r.recovered]
        for r, want, got in pairs:
            rel = (got - want) / want if want and math.isfinite(want) else math.nan
            static = f"  (plant static {r.static_n:.4g})" if key == "breakaway_n" else ""
            print(
                f"    {key:14s} {r.case.name:40s} plant {want:10.4g}  reported {got:10.4g}  "
                f"({fmt(rel, '+.0%')}){static}"
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
        + ("diag reused" if r.reused else f"diag {r.diag_s:4.0f} s, CPU {r.diag_cpu_s:4.0f} s"),
        flush=True,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant", choices=PLANTS, default="reference", help="default reference")
    ap.add_argument("--seeds", type=int, default=2, help="seeds per case (default 2)")
    ap.add_argument(
        "--first-seed",
        type=int,
        help=f"default {FIRST_SEED['reference']} (reference), {FIRST_SEED['holdout']} (holdout)",
    )
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
    first = FIRST_SEED[args.plant] if args.first_seed is None else args.first_seed
    seeds = list(range(first, first + args.seeds))
    if args.fresh and args.plant != "reference":
        ap.error("--fresh: the reference plant's cases only (a held-out seed draws anew)")
    if args.plant == "holdout":
        cases = holdout_cases(seeds)
    else:
        cases = fresh_cases(seeds) if args.fresh else make_cases(seeds)
    if args.only:
        cases = [c for c in cases if c.name.startswith(tuple(args.only.split(",")))]
        if not cases:
            ap.error(f"--only {args.only}: no case's name starts with that")
    print(
        f"{len(cases)} {args.plant}-plant sweeps, seeds {seeds}, {args.jobs} in parallel; clicks "
        f"{CLICKS} x 0.5/1/1.5 Hz; cpus {os.cpu_count()}, load {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    t0 = time.perf_counter()
    rows: list[Row] = []
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        # The longest first (more effects, air: more rounds, a chamber to integrate), so
        # the last minutes do not run one long case beside an idle core; the order is
        # the submission's only, each case's result is its own.
        longest = sorted(
            cases,
            key=lambda c: (
                -(len(c.asked) or c.holdout.count("_")),
                "comp" not in (c.holdout or " ".join(c.asked)),
            ),
        )
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
