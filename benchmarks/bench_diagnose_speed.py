"""Speed of `shockdyno diagnose`: this checkout against another (an earlier commit), on the
same sweeps, in the same run, with the verdicts side by side.

Run: .venv/bin/python benchmarks/bench_diagnose_speed.py --before DIR
         [--cases comp_mid,pair_comp_fric,...] [--seed 0] [--sim-rig compressibility#2,...]
         [--workers 2] [--rounds 1] [--cache DIR]

DIR is a checkout of the code to compare with, with its own environment (`git worktree add
/tmp/base 06fb859 && make -C /tmp/base .venv/.installed`). Each sweep is diagnosed as a user
would (`shockdyno diagnose REC.mcap --json DIAG.json --workers N`, the whole library) by
each checkout's own command, before and after alternating (the order flips from sweep to
sweep and round to round, so a machine whose load drifts favours neither). Printed per
sweep: wall time and CPU time (the command and its worker processes) of each, their
ratios, and each verdict (the physics claimed, the calibrations that moved, the
unexplained regions) with whether they agree and how far the claimed parameters and the
calibrated values moved in units of their σ, and the final model's E_t (mean over the
tests) of each; then the geometric means of the ratios.

Sweeps:
- the held-out plant's (benchmarks/holdout: clicks 2, 5, 10, 15, 20 x 0.5 / 1 / 1.5 Hz,
  30 mm, 1 kHz, 15 tests), imported from its CSVs with `shockdyno import` (`--cases`:
  bench_holdout.py's case names; default the ones issue 44 timed: seal stiction, air beside
  stiction, air alone);
- the simulated rig's (`--sim-rig`: bench_diagnose.py's case names, clicks 0, 7, 14, 21 x
  0.5 / 1 / 1.5 Hz, 12 tests; seed --seed + 1).

Timings are wall clock on a machine others may be using: the ratios, taken a few seconds
apart, are the figure; each line also prints the load average.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_diagnose as bd
import bench_holdout as bh
from holdout.sweep import run_sweep

HERE = Path(sys.executable).parent
DEFAULT_CASES = "fric_mid,pair_comp_fric,comp_mid"


@dataclass
class Run:
    wall_s: float
    cpu_s: float
    load: float
    diag: dict[str, Any]


def holdout_recording(name: str, seed: int, cache: Path) -> Path:
    """The held-out plant's sweep of case `name`, imported as a user would."""
    case = next(c for c in bh.CASES if c.name == name)
    d = cache / f"{name}-s{seed}"
    if not (d / "manifest.csv").exists():
        run_sweep(bh.draw(case, seed), d, seed=bh.noise_seed(case, seed))
    rec = d / "REC.mcap"
    if not rec.exists():
        cmd = [str(HERE / "shockdyno"), "import", str(d / "manifest.csv"), "-o", str(rec)]
        subprocess.run(cmd, check=True, capture_output=True)
    return rec


def simrig_recording(name: str, seed: int, cache: Path) -> tuple[Path, int]:
    """bench_diagnose's sim-rig sweep of case `name` (e.g. compressibility#2) and its seed
    (make_cases draws seeds `seed`..`seed` + 2; the last of the name's is recorded)."""
    cases = {c.name.split(" ")[0]: c for c in bd.make_cases(False, seed)}
    case = cases[name]
    return bd.record(case, cache, f"sim-{name.replace('#', '-')}-s{case.seed}"), case.seed


def diagnose(venv: Path, rec: Path, out: Path, workers: int) -> Run:
    cmd = [str(venv / "bin" / "shockdyno"), "diagnose", str(rec), "--json", str(out)]
    cmd += ["--force", "--workers", str(workers)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        tail = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["?"]
        raise RuntimeError(f"{cmd[0]} diagnose failed ({done.returncode}): {tail[0]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return Run(wall, cpu, os.getloadavg()[0], json.loads(out.read_text()))


def _region(u: dict[str, Any]) -> str:
    """An unexplained region by where it is (stroke, displacement and speed band,
    frequencies, near reversal); its share and RMS are figures, free to move."""
    where = {k: u.get(k) for k in ("stroke", "frequencies_hz", "near_reversal")}
    for k in ("x_range_m", "v_range_m_s"):
        where[k] = [round(float(x), 4) for x in u.get(k) or []]
    return json.dumps(where, sort_keys=True)


def _regions(v: dict[str, Any]) -> list[dict[str, Any]]:
    """The unexplained regions, listed one an entry (before issue 45) or inside each
    described residual's `regions` (after): a checkout on either side compares."""
    return [r for u in v.get("unexplained") or [] for r in u.get("regions") or [u]]


def verdict(d: dict[str, Any]) -> dict[str, Any]:
    """What must not change: the physics, the calibrations that moved, the unexplained."""
    v = d["verdict"]
    return {
        "physics": list(v["physics"]),
        "calibrated": sorted(r["parameter"] for r in v["calibration"] if r.get("moved")),
        "unexplained": sorted(_region(u) for u in _regions(v)),
    }


def short(d: dict[str, Any]) -> str:
    v = verdict(d)
    cal = ",".join(p.split(".")[0] if "valve" not in p else p for p in v["calibrated"])
    return (
        f"[{','.join(v['physics']) or '-'}] cal [{cal or '-'}] {len(v['unexplained'])} unexplained"
    )


def figures_moved(a: dict[str, Any], b: dict[str, Any]) -> float:
    """The largest move, in σ (the larger of the two), of a claimed term's fitted parameter
    or a calibrated value between two diagnoses with the same verdict."""
    worst = 0.0

    def pairs(d: dict[str, Any]) -> dict[str, tuple[float, float]]:
        out = {}
        for f in d["findings"]:
            if f.get("claimed"):
                for k, e in (f.get("parameters") or {}).items():
                    if isinstance(e, dict) and not e.get("fixed"):
                        out[f"{f['physics']}.{k}"] = (e["value"], e["sd"])
        for r in d["verdict"]["calibration"]:
            out[r["parameter"]] = (r["fitted"], r["sd"])
        return out

    pa, pb = pairs(a), pairs(b)
    for k in pa.keys() & pb.keys():
        (va, sa), (vb, sb) = pa[k], pb[k]
        sd = max(x for x in (sa, sb, 0.0) if x is not None and math.isfinite(x))
        if va is None or vb is None:
            continue
        if sd > 0:
            worst = max(worst, abs(va - vb) / sd)
        elif va != vb:
            worst = math.inf
    return worst


def mean_e_t_after(d: dict[str, Any]) -> float:
    """The final model's E_t, the mean over the tests (what the diagnosis left)."""
    got = [t["E_t_after"] for t in d.get("tests") or [] if t.get("E_t_after") is not None]
    return sum(got) / len(got) if got else math.nan


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="the checkout to compare with")
    ap.add_argument("--cases", default=DEFAULT_CASES, help="held-out plant cases (a,b,...)")
    ap.add_argument("--sim-rig", default="", help="bench_diagnose cases (compressibility#2,..)")
    ap.add_argument(
        "--seed",
        type=int,
        default=0,
        help="held-out plant seed (sim-rig: make_cases from +1, i.e. seed + 3)",
    )
    ap.add_argument("--workers", type=int, default=2, help="diagnose --workers (default 2)")
    ap.add_argument("--rounds", type=int, default=1, help="timings per sweep and checkout")
    ap.add_argument("--cache", type=Path, help="keep the recordings here (reused)")
    args = ap.parse_args()
    venv_before = args.before / ".venv"
    venv_after = HERE.parent
    if not (venv_before / "bin" / "shockdyno").exists():
        ap.error(f"--before: no {venv_before}/bin/shockdyno (make .venv/.installed there)")
    cache = args.cache or Path(tempfile.mkdtemp(prefix="bench-diag-speed-"))
    cache.mkdir(parents=True, exist_ok=True)
    sweeps: list[tuple[str, Path]] = []
    for name in filter(None, args.cases.split(",")):
        sweeps.append((f"holdout {name} s{args.seed}", holdout_recording(name, args.seed, cache)))
    for name in filter(None, args.sim_rig.split(",")):
        rec, seed = simrig_recording(name, args.seed + 1, cache)
        sweeps.append((f"sim-rig {name} s{seed}", rec))
    print(
        f"diagnose --workers {args.workers}, whole library; before = {args.before}, after = "
        f"{venv_after.parent}; {len(sweeps)} sweeps x {args.rounds} rounds; cpus "
        f"{os.cpu_count()}, load average {os.getloadavg()[0]:.1f} (shared machine)",
        flush=True,
    )
    ratios_wall, ratios_cpu, agree = [], [], 0
    head = f"{'sweep':34s} {'before wall/cpu s':>18s} {'after wall/cpu s':>17s}"
    print(f"{head} {'wall':>6s} {'cpu':>6s}  verdict before | after")
    for i, (label, rec) in enumerate(sweeps):
        for r in range(args.rounds):
            order = ("before", "after") if (i + r) % 2 == 0 else ("after", "before")
            runs: dict[str, Run] = {}
            for which in order:
                venv = venv_before if which == "before" else venv_after
                out = rec.parent / f"DIAG-speed-{which}.json"
                runs[which] = diagnose(venv, rec, out, args.workers)
            b, a = runs["before"], runs["after"]
            rw, rc = a.wall_s / b.wall_s, a.cpu_s / b.cpu_s
            ratios_wall.append(rw)
            ratios_cpu.append(rc)
            same = verdict(a.diag) == verdict(b.diag)
            agree += same
            moved = figures_moved(b.diag, a.diag) if same else math.nan
            print(
                f"{label:34s} {b.wall_s:8.1f} /{b.cpu_s:7.1f} {a.wall_s:8.1f} /{a.cpu_s:7.1f} "
                f"{rw:6.3f} {rc:6.3f}  {short(b.diag)} | {short(a.diag)} "
                f"({'same' if same else 'DIFFERENT'}"
                + (f", figures within {moved:.2f} σ" if same else "")
                + f"; E_t after {mean_e_t_after(b.diag):.4f}/{mean_e_t_after(a.diag):.4f}"
                + f"; {'/'.join(order)}, load {b.load:.1f}/{a.load:.1f})",
                flush=True,
            )
    n = len(ratios_wall)
    if n:
        gw = math.exp(sum(map(math.log, ratios_wall)) / n)
        gc = math.exp(sum(map(math.log, ratios_cpu)) / n)
        print(
            f"\nafter / before, geometric mean over {n} timings: wall {gw:.3f} ({1 / gw:.2f}x "
            f"faster), CPU {gc:.3f} ({1 / gc:.2f}x less); verdicts the same on {agree} of {n}"
        )


if __name__ == "__main__":
    main()
