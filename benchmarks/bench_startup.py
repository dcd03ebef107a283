"""Start-up time of the command line: `shockdyno --help` and a cheap command (`info` on the
example recording), this tree against another revision's, runs interleaved.

Baseline (same run): the same commands from `git archive REV src` (default: main), so the
figure is the change's and not the machine's load. Wall time is what a user waits; CPU time
(user + sys of the child) is what the imports cost, and moves less with the load of a
shared machine.

    .venv/bin/python benchmarks/bench_startup.py [--against REV] [--runs 10]
    .venv/bin/python benchmarks/bench_startup.py --marginal MODULE [MODULE ...]

`--marginal` gives each module's own cost on top of what every command already pays (the
parser built, so every command module imported): a fresh process per module and round.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "recordings" / "examples" / "example.mcap"
MAIN = "import sys; from shockdyno.cli import main; sys.exit(main())"
COMMANDS = {"--help": ["--help"], "info": ["info", str(EXAMPLE)]}
MARGINAL = """
import importlib, sys, time
from shockdyno.cli import build_parser
build_parser()
before = set(sys.modules)
t, c = time.perf_counter(), time.process_time()
importlib.import_module(sys.argv[1])
print(time.perf_counter() - t, time.process_time() - c, len(set(sys.modules) - before))
"""


def _timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, check=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _env(src: Path) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(src)}


def compare(against: str, runs: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        archive = subprocess.run(
            ["git", "-C", str(ROOT), "archive", against, "src"], capture_output=True, check=True
        ).stdout
        subprocess.run(["tar", "-x", "-C", tmp], input=archive, check=True)
        trees = {against: Path(tmp) / "src", "this tree": ROOT / "src"}
        times: dict[tuple[str, str], list[tuple[float, float]]] = {
            (t, c): [] for t in trees for c in COMMANDS
        }
        for _ in range(runs):
            for name, args in COMMANDS.items():
                for tree, src in trees.items():
                    times[tree, name].append(_timed([sys.executable, "-c", MAIN, *args], _env(src)))
    print(f"load average at the end: {os.getloadavg()[0]:.1f}; {runs} runs each, interleaved")
    print(f"{'command':<8} {'tree':<10} {'wall ms':>8} {'cpu ms':>8}  (medians)")
    for name in COMMANDS:
        medians = {}
        for tree in trees:
            got = times[tree, name]
            medians[tree] = (
                statistics.median(w for w, _ in got) * 1e3,
                statistics.median(c for _, c in got) * 1e3,
            )
            print(f"{name:<8} {tree:<10} {medians[tree][0]:8.0f} {medians[tree][1]:8.0f}")
        new, old = medians["this tree"], medians[against]
        print(f"{name:<8} {'ratio':<10} {new[0] / old[0]:8.2f} {new[1] / old[1]:8.2f}")


def marginal(modules: list[str], rounds: int) -> None:
    got: dict[str, list[tuple[float, float, int]]] = {m: [] for m in modules}
    for _ in range(rounds):
        for m in modules:
            out = subprocess.run(
                [sys.executable, "-c", MARGINAL, m], capture_output=True, text=True, check=True
            ).stdout.split()
            got[m].append((float(out[0]), float(out[1]), int(out[2])))
    print(f"{'cpu ms':>8} {'wall ms':>8} {'modules':>8}  (median of {rounds}, after the parser)")
    rows = sorted(
        (
            statistics.median(c for _, c, _ in v) * 1e3,
            statistics.median(w for w, _, _ in v) * 1e3,
            v[0][2],
            m,
        )
        for m, v in got.items()
    )
    for cpu, wall, n, m in reversed(rows):
        print(f"{cpu:8.1f} {wall:8.1f} {n:8d}  {m}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--against", default="main", help="the baseline revision")
    p.add_argument("--runs", type=int, default=10)
    p.add_argument("--marginal", nargs="+", metavar="MODULE")
    args = p.parse_args()
    if args.marginal:
        marginal(args.marginal, args.runs)
    else:
        compare(args.against, args.runs)


if __name__ == "__main__":
    main()
