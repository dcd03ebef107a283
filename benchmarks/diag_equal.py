"""Behaviour unchanged: DIAG.json of two checkouts, byte for byte apart from timings, and
the CPU time of one diagnose in each (issue 48: a refactor of the search must not change
what it finds nor make it slower).

Recordings: the committed example, and two held-out-plant sweeps with a concealed effect
(tests/holdout/plant.py via benchmarks/bench_holdout.py's cases: `fric_mid` and
`comp_mid`, fixed seed), swept and imported once into --work. Each recording is diagnosed
by each Python given (each venv runs its own checkout's code), in one process per run,
and the DIAG.json documents (`diagnose_file`'s, serialised as `diagnose --json` does) are
compared after removing the timing keys (`wall_s`). CPU is `time.process_time()` around
`diagnose_file` in the child (the diagnosis, not the interpreter's start: the modules
`diagnose_file` imports inside itself are imported before the clock starts, so a checkout
that imports them at the top is not timed as faster).

    .venv/bin/python benchmarks/diag_equal.py --before /work/main/.venv/bin/python \\
        [--after .venv/bin/python] [--work DIR] [--seed 101] [--only example,fric_mid]
        [--verdict] [--workers 2]

--verdict: for a change that may move figures (issue 44: solves that stop once converged),
the documents must agree on what bench_diagnose_speed.py's `verdict` holds (the physics
claimed, the calibrations that moved, the unexplained regions), and the largest move of a
claimed parameter or a calibrated value in units of its σ is printed.

--workers N: each diagnosis with N worker processes (`diagnose --workers N`; default 1),
for a change to how the work is spread; the CPU printed is then the diagnosis's and its
workers'.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "recordings" / "examples" / "example.mcap"
TIMING_KEYS = {"wall_s"}

# Run in the child: one diagnose, its document as DIAG.json's text, and its CPU time.
CHILD = """
import json, resource, sys, time
from pathlib import Path
from shockdyno import schema
from shockdyno.diagnose.file import diagnose_file
import shockdyno.diagnose.engine, shockdyno.diagnose.verdict  # loaded before the clock
rec, out, workers = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3])
t = time.process_time()
_, doc = diagnose_file(rec, workers=workers)
done = resource.getrusage(resource.RUSAGE_CHILDREN)  # the workers, ended with the diagnosis
cpu = time.process_time() - t + done.ru_utime + done.ru_stime
out.write_text(json.dumps(schema.to_json(doc), indent=2, sort_keys=True))
print(json.dumps({"cpu_s": cpu}))
"""


def _holdout_recording(case_name: str, seed: int, work: Path) -> Path:
    """A held-out-plant sweep of `case_name` at `seed`, imported to an MCAP (made once)."""
    d = work / f"{case_name}-s{seed}"
    rec = d / "REC.mcap"
    if rec.exists():
        return rec
    sys.path.insert(0, str(REPO / "benchmarks"))
    import bench_holdout as bh

    case = next(c for c in bh.CASES if c.name == case_name)
    bh.run_sweep(bh.draw(case, seed), d, seed=bh.noise_seed(case, seed))
    cmd = [sys.executable, "-m", "shockdyno.cli", "import", str(d / "manifest.csv")]
    subprocess.run([*cmd, "-o", str(rec)], check=True, capture_output=True)
    return rec


def _strip(doc: Any) -> Any:
    if isinstance(doc, dict):
        return {k: _strip(v) for k, v in doc.items() if k not in TIMING_KEYS}
    if isinstance(doc, list):
        return [_strip(v) for v in doc]
    return doc


def child(python: str, code: str, rec: Path, *args: str) -> dict[str, Any]:
    """The JSON `code` printed last, run by `python` on `rec` (each venv its own checkout)."""
    done = subprocess.run(
        [python, "-c", code, str(rec), *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=tempfile.gettempdir(),  # not the repo: each venv imports its own checkout
    )
    if done.returncode != 0:
        raise SystemExit(f"{python} on {rec}: failed\n{done.stderr[-2000:]}")
    out: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return out


def run(python: str, rec: Path, out: Path, workers: int = 1) -> tuple[str, float]:
    """(DIAG.json's text without timings, CPU seconds of the diagnosis and its workers) by
    `python`."""
    cpu = float(child(python, CHILD, rec, str(out), str(workers))["cpu_s"])
    text = json.dumps(_strip(json.loads(out.read_text())), indent=2, sort_keys=True)
    return text, cpu


def _verdicts(name: str, before: str, after: str) -> bool:
    """Whether two DIAG.json texts give the same verdict (said, with how far the figures
    moved)."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    import bench_diagnose_speed as bds

    a, b = json.loads(before), json.loads(after)
    same = bool(bds.verdict(a) == bds.verdict(b))
    moved = f", figures within {bds.figures_moved(a, b):.2f} σ" if same else ""
    print(
        f"{name:10s} verdict {'the same' if same else 'DIFFERENT'}: {bds.short(a)} | "
        f"{bds.short(b)}{moved}; E_t after {bds.mean_e_t_after(a):.4f}/"
        f"{bds.mean_e_t_after(b):.4f}"
    )
    return same


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="Python of the reference checkout")
    ap.add_argument("--after", default=sys.executable, help="Python of the changed checkout")
    ap.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()) / "diag_equal")
    ap.add_argument("--seed", type=int, default=101, help="the held-out plants' seed")
    ap.add_argument("--only", default="example,fric_mid,comp_mid")
    ap.add_argument("--verdict", action="store_true", help="the verdicts equal, not the bytes")
    ap.add_argument("--workers", type=int, default=1, help="diagnose --workers (default 1)")
    args = ap.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    names = args.only.split(",")
    recs = {
        n: EXAMPLE if n == "example" else _holdout_recording(n, args.seed, args.work) for n in names
    }
    equal = True
    cpu_total = {"before": 0.0, "after": 0.0}
    for name, rec in recs.items():
        texts = {}
        for side in ("before", "after"):
            out = args.work / f"{name}.{side}.DIAG.json"
            texts[side], cpu = run(getattr(args, side), rec, out, args.workers)
            cpu_total[side] += cpu
            print(f"{name:10s} {side:6s} CPU {cpu:7.1f} s", flush=True)
        same = texts["before"] == texts["after"]
        claimed = json.loads(texts["after"])["verdict"]["physics"]
        print(f"{name:10s} DIAG.json {'byte-equal' if same else 'DIFFERS'}; physics {claimed}")
        if args.verdict and not same:
            same = _verdicts(name, texts["before"], texts["after"])
        equal &= same
    ratio = cpu_total["after"] / cpu_total["before"]
    agree = ("verdicts the same" if args.verdict else "byte-equal") if equal else "DIFFERENT"
    print(
        f"all: {agree}; CPU before {cpu_total['before']:.1f} s, "
        f"after {cpu_total['after']:.1f} s (after/before {ratio:.3f})"
    )
    if not equal:
        raise SystemExit(1)


if __name__ == "__main__":
    main()
