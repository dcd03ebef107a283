"""Physics outside the library: does `diagnose` locate, describe and model effects that no
term has, and claim no discovered term where a named one or nothing is right?

The plants are benchmarks/holdout's (written apart from the library), with the effects of
benchmarks/unnamed/effects.py added (a load-cell zero drift, a bypass groove over part of
the stroke, rod-guide friction from a side load, play in the LVDT's linkage, shim-stack
hysteresis), and holdout's own named-effect cases beside them (clean, aerated oil, vapour,
seal friction, a force-channel lag, heat, a bump stop) with the fixture mass that the
library now names (`fixture_mass`). Each recording is written as CSVs and diagnosed as a
user would:

    shockdyno import manifest.csv -o REC.mcap
    shockdyno diagnose REC.mcap --json DIAG.json

    .venv/bin/python benchmarks/bench_unnamed.py [--seeds N] [--first-seed S] [--cache DIR]
                                                  [--jobs J] [--workers W]
                                                  [--only NAME[,NAME...]]

A seed draws every strength from its case's range (unnamed/effects.py CASES,
bench_holdout.py BASE) and the sensors' noise, so each seed is a new plant.

Scored, per recording (DIAG.json `verdict.unexplained[0]` and `verdict.physics`):
- located: structure was left significant and described (`verdict.unexplained` not empty);
- described as: the families of the signals the discovered term is made of (its top
  `follows` where no term was formed), against the family the effect's physics has;
- modelled: an unnamed term claimed whose held-out gain is at least 0.5 and whose
  features are of the effect's family;
- false positives: for an unnamed effect, any library physics claimed (a wrong named
  physics); for a clean or named-effect recording, an unnamed term claimed (and, shown
  apart, a named physics claimed that the plant did not have).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_holdout as holdout
from holdout.sweep import run_sweep
from unnamed import effects

# The family of signals each unnamed effect's physics follows (features.py's families).
EXPECTED = {
    "drift": ("time",),
    "groove": ("position × bleed", "position × damping"),
    "sideload": ("position × friction",),
    "lvdt_play": ("force in travel", "force in time"),
    "valve_hyst": ("force hysteresis", "force in time"),
}
NAMED = ("clean", "comp_mid", "cav_mid", "fric_mid", "lag_mid", "thermal_mid", "contact_mid")
MIN_GAIN = 0.5  # the bar: a discovered term removes half the held-out structure


@dataclass(frozen=True)
class Job:
    name: str  # an unnamed effect, "fixture", or a holdout case
    seed: int

    @property
    def unnamed(self) -> bool:
        return self.name in EXPECTED


def _cli() -> str:
    exe = Path(sys.executable).parent / "shockdyno"
    return str(exe) if exe.exists() else "shockdyno"


def _run(cmd: list[str], log: Path) -> None:
    with log.open("w") as fh:
        r = subprocess.run(cmd, stdout=fh, stderr=subprocess.STDOUT, check=False)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({r.returncode}); see {log}")


def record(job: Job, d: Path) -> None:
    if job.name in effects.BY_NAME:
        extra = effects.draw(effects.BY_NAME[job.name], job.seed)
        effects.record_sweep(extra, d, seed=effects.noise_seed(job.name, job.seed))
    else:
        case = holdout._BY_NAME[job.name]
        run_sweep(holdout.draw(case, job.seed), d, seed=holdout.noise_seed(case, job.seed))


def run_one(job: Job, cache: Path, workers: int | None = None) -> dict[str, Any]:
    """Sweep, import and diagnose one recording (reusing what the cache holds)."""
    d = cache / f"{job.name}-s{job.seed}"
    manifest, rec, diag = d / "manifest.csv", d / "REC.mcap", d / "DIAG.json"
    timing: dict[str, float] = {}
    if not (manifest.exists() and (d / "truth.json").exists()):
        t = time.perf_counter()
        record(job, d)
        timing["sweep_s"] = time.perf_counter() - t
    if not rec.exists():
        _run([_cli(), "import", str(manifest), "-o", str(rec)], d / "import.log")
    if not diag.exists():
        t = time.perf_counter()
        more = [] if workers is None else ["--workers", str(workers)]
        _run([_cli(), "diagnose", str(rec), "--json", str(diag), *more], d / "diagnose.log")
        timing["diagnose_s"] = time.perf_counter() - t
    truth = json.loads((d / "truth.json").read_text())
    return {"job": job, "truth": truth, "diag": json.loads(diag.read_text()), "timing": timing}


def _families(left: dict[str, Any]) -> list[str]:
    """The families of the discovered term's features (of the top signal followed, where no
    term was formed)."""
    term = left.get("term") or {}
    items = term.get("coefficients") or left.get("follows", [])[:1]
    return list(dict.fromkeys(str(c.get("family", "?")) for c in items))


def score(r: dict[str, Any]) -> dict[str, Any]:
    job: Job = r["job"]
    verdict = r["diag"]["verdict"]
    left = (verdict.get("unexplained") or [{}])[0]
    term = left.get("term") or {}
    named = [p for p in verdict.get("physics", []) if p in holdout.PHYSICS or p == "fixture_mass"]
    truth_named = list(r["truth"].get("physics", []))
    if job.name == "fixture":
        truth_named.append("fixture_mass")
    gain = term.get("heldout_gain")
    families = _families(left) if left else []
    claimed = bool(term.get("claimed"))
    out = {
        "case": job.name,
        "seed": job.seed,
        "located": bool(left),
        "where": _where(left) if left else "-",
        "described": ", ".join(families) or "-",
        "form": term.get("form", "-"),
        "gain": gain,
        "claimed": claimed,
        "named": named,
        "truth": truth_named,
    }
    if job.unnamed:
        expected = EXPECTED[job.name]
        good = (
            claimed
            and gain is not None
            and gain >= MIN_GAIN
            and any(f in expected for f in families)
        )
        out["modelled"] = good
        out["fp"] = [p for p in named if p not in truth_named]
    else:
        out["modelled"] = None
        out["fp"] = ["unnamed"] if claimed else []
        out["named_fp"] = [p for p in named if p not in truth_named]
    return out


def _where(left: dict[str, Any]) -> str:
    x = left.get("x_range_m") or [math.nan, math.nan]
    return (
        f"{left.get('stroke', '?')} {1e3 * x[0]:+.0f}…{1e3 * x[1]:+.0f} mm, {left.get('phase', '')}"
    )


def summarise(rows: list[dict[str, Any]]) -> None:
    print("\nUnnamed effects (no library term has them):")
    print(
        f"  {'effect':<11} {'seed':>4}  {'located where':<58} {'described as':<22} "
        f"{'held-out':>8}  {'claimed':<7} {'modelled':<8} false positives  form"
    )
    for o in (o for o in rows if o["modelled"] is not None):
        gain = "-" if o["gain"] is None else f"{o['gain']:.2f}"
        claimed, modelled = ("yes" if o["claimed"] else "no"), ("yes" if o["modelled"] else "NO")
        print(
            f"  {o['case']:<11} {o['seed']:>4}  {o['where'][:58]:<58} {o['described'][:22]:<22} "
            f"{gain:>8}  {claimed:<7} {modelled:<8} {','.join(o['fp']) or '0':<15}  {o['form']}"
        )
    print("\nClean and named-effect sweeps (a discovered term claimed is a false positive):")
    print(
        f"  {'case':<12} {'seed':>4}  {'truth':<26} {'named claimed':<36} "
        f"{'unnamed claimed':<15} {'held-out':>8}  form tried"
    )
    for o in (o for o in rows if o["modelled"] is None):
        gain = "-" if o["gain"] is None else f"{o['gain']:.2f}"
        print(
            f"  {o['case']:<12} {o['seed']:>4}  {','.join(o['truth']) or '-':<26} "
            f"{','.join(o['named']) or '-':<36} {'YES' if o['fp'] else 'no':<15} {gain:>8}  "
            f"{o['form'] if o['form'] != '-' else ''}"
        )
    effect = [o for o in rows if o["modelled"] is not None]
    other = [o for o in rows if o["modelled"] is None]
    modelled = sum(bool(o["modelled"]) for o in effect)
    wrong_named = sum(bool(o["fp"]) for o in effect)
    both = sum(bool(o["modelled"]) and not o["fp"] for o in effect)
    unnamed_fp = sum(bool(o["fp"]) for o in other)
    print(
        f"\nunnamed effects modelled (claimed, gain >= {MIN_GAIN}, the effect's family): "
        f"{modelled}/{len(effect)}; with a wrong named physics claimed: "
        f"{wrong_named}/{len(effect)}; modelled and no wrong named physics: {both}/{len(effect)}"
    )
    print(f"discovered terms claimed on clean or named-effect sweeps: {unnamed_fp}/{len(other)}")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=1, help="seeds per case (default 1)")
    ap.add_argument("--first-seed", type=int, default=950, help="first seed (default 950)")
    ap.add_argument("--cache", type=Path, default=None, help="keep recordings here")
    ap.add_argument("--jobs", type=int, default=1, help="recordings at once (default 1)")
    ap.add_argument(
        "--workers", type=int, default=None, help="each diagnosis's --workers (default: its own)"
    )
    ap.add_argument("--only", default="", help="cases, comma-separated (default: all)")
    args = ap.parse_args(argv)
    names = [*EXPECTED, "fixture", *NAMED]
    if args.only:
        names = [n for n in args.only.split(",") if n]
    cache = args.cache or Path(tempfile.mkdtemp(prefix="unnamed-"))
    cache.mkdir(parents=True, exist_ok=True)
    jobs = [Job(n, s) for s in range(args.first_seed, args.first_seed + args.seeds) for n in names]
    print(f"{len(jobs)} recordings, cache {cache}, {args.jobs} at once", flush=True)
    rows = []
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(run_one, j, cache, args.workers): j for j in jobs}
        for fut, j in futures.items():
            try:
                r = fut.result()
            except Exception as exc:  # one failed recording does not stop the rest
                print(f"FAILED {j.name} s{j.seed}: {exc}", flush=True)
                continue
            o = score(r)
            rows.append(o)
            tm = " ".join(f"{k} {v:.0f}" for k, v in r["timing"].items())
            print(f"done {j.name} s{j.seed}: {o['form']} (gain {o['gain']}) {tm}", flush=True)
    print(f"wall time {time.perf_counter() - t0:.0f} s")
    summarise(rows)


if __name__ == "__main__":
    main()
