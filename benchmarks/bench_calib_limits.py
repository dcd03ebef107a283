"""Calibration with limits (issue 44): held-out plant sweeps diagnosed by two trees.

Run:  .venv/bin/python benchmarks/bench_calib_limits.py --seed 9401 --cache DIR \\
          --label after [--python OTHER/.venv/bin/python --label before] [--only CASES]

For each case (bench_holdout.py's, or `A+B` for two of them together) and the seed, a
sweep of the held-out plant (tests/holdout/plant.py) at clicks 2 and 12 x 0.5 and 1.5 Hz
(4 tests, 4 measured cycles) is written as CSV files and imported, as bench_holdout does,
then `shockdyno diagnose REC.mcap --workers 1 --no-history` is run with the `shockdyno` of
`--python`'s environment (default: this one), its DIAG.json kept as
DIR/CASE-sSEED-c2_12-f0.5_1.5/DIAG-LABEL.json (reused when there). Printed per recording
and label: truth, claimed, mean E_t before -> after, every calibrated value that moved
(x the spec's; `BEYOND`: beyond its tolerance; `asked A`: what a fit asked before it was
held), and the verdict's calibration sentences. `--spec`: diagnose with another spec (a
drawing whose Coulomb friction is a third of the damper's: a value beyond its tolerance).

Cases (the issue's aerated oil beside seal stiction, in the plant's own forms):
  comp_hi+fric_hi    1.5-3 % free air (bubbles κ 1.0-1.3) beside an elastic seal lip,
                     breakaway 100-150 N over the 35 N Coulomb, Stribeck 3-8 mm/s, drag
                     120-200 N·s/m
  comp_mid+fric_hi   0.5-1 % free air beside the same lip
and clean, spec_charge, spec_preload (a spec value mis-set within its tolerance) and the
named-effect sweeps fric_mid, comp_mid, lag_mid, contact_mid. Truth is what the plant did.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_holdout as bh
from holdout.recording import holdout_recording

CLICKS = (2, 12)
FREQS = (0.5, 1.5)
CASES = (
    "comp_hi+fric_hi",
    "comp_mid+fric_hi",
    "clean",
    "spec_charge",
    "spec_preload",
    "fric_mid",
    "comp_mid",
    "lag_mid",
    "contact_mid",
)


def case(name: str) -> bh.Case:
    known = {c.name: c for c in bh.CASES}
    return known[name] if name in known else bh._combo(name, *name.split("+"))


def folder(cache: Path, name: str, seed: int) -> Path:
    clicks = "_".join(str(c) for c in CLICKS)
    freqs = "_".join(f"{f:g}" for f in FREQS)
    return cache / f"{name}-s{seed}-c{clicks}-f{freqs}"


def make(name: str, seed: int, cache: Path) -> Path:
    """The sweep's REC.mcap (made once) and truth.txt: the plant's effects, its physics
    and its values."""
    d = folder(cache, name, seed)
    rec = d / "REC.mcap"
    if not rec.exists():
        d.mkdir(parents=True, exist_ok=True)
        c = case(name)
        eff = bh.draw(c, seed)
        _, truth = holdout_recording(eff, d, bh.noise_seed(c, seed), clicks=CLICKS, freqs=FREQS)
        values = json.dumps(truth.values, default=str)
        (d / "truth.txt").write_text(f"{eff}\n{truth.physics()}\n{values}\n")
    return rec


def diagnose(rec: Path, python: Path, label: str, spec: Path | None) -> dict[str, Any]:
    out = rec.parent / f"DIAG-{label}.json"
    if not out.exists():
        exe = python.parent / "shockdyno"
        cmd = [str(exe), "diagnose", str(rec), "--json", str(out), "--workers", "1"]
        cmd += ["--spec", str(spec)] if spec else []
        t = time.perf_counter()
        done = subprocess.run([*cmd, "--no-history"], capture_output=True, text=True)
        (rec.parent / f"diag-{label}.log").write_text(done.stdout + done.stderr)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)}: exit {done.returncode}")
        print(f"  ({label} diagnosed in {time.perf_counter() - t:.0f} s)", flush=True)
    doc: dict[str, Any] = json.loads(out.read_text())
    return doc


def line(name: str, seed: int, label: str, truth: str, doc: dict[str, Any]) -> str:
    v = doc["verdict"]
    n = len(doc["tests"])
    before = sum(t["E_t_before"] for t in doc["tests"]) / n
    after = sum(t["E_t_after"] for t in doc["tests"]) / n
    cal = []
    for r in v["calibration"]:
        if not (r.get("moved") or r.get("asked")) or not r["spec_value"]:
            continue
        word = f"{r['parameter']} {r['fitted'] / r['spec_value']:.3g}x"
        if r.get("beyond_tolerance"):
            word += " BEYOND"
        if r.get("asked") is not None:
            word += f" asked {r['asked'] / r['spec_value']:.3g}x"
        cal.append(word)
    sentences = [s for s in v["text"].split(". ") if "alibrat" in s or "tolerance" in s]
    return (
        f"{name} s{seed} {label:<7} truth {truth:<30} claimed {v['physics']}  "
        f"E_t {before:.4f} -> {after:.4f}  left {v['remaining_rms_n']:.3g} N "
        f"(p {v['remaining_p_value']:.3g})  wall {doc['info']['wall_s']:.0f} s\n"
        f"    calibrated: {', '.join(cal) or '-'}\n"
        + "".join(f"    | {s.strip()}\n" for s in sentences)
    )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--cache", type=Path, required=True)
    ap.add_argument("--python", type=Path, default=Path(sys.executable))
    ap.add_argument("--label", default="this")
    ap.add_argument("--only", default=",".join(CASES), help="cases, comma-separated")
    ap.add_argument("--spec", type=Path, default=None, help="diagnose with this spec")
    args = ap.parse_args(argv)
    for name in args.only.split(","):
        rec = make(name, args.seed, args.cache)
        truth = (rec.parent / "truth.txt").read_text().splitlines()[1]
        print(
            line(
                name,
                args.seed,
                args.label,
                truth,
                diagnose(rec, args.python, args.label, args.spec),
            )
        )


if __name__ == "__main__":
    main()
