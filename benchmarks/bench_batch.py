"""Batch throughput: N recordings fitted serially and on a 2-worker LocalCluster, same run.

    .venv/bin/python benchmarks/bench_batch.py [--recordings 24] [--workers 2]

Prints the serial and the cluster wall time (the cluster's with and without its start),
the throughput ratio (aim >= 1.7x on 2 cores), the per-task scheduling overhead (a
no-op task's round trip through the same client), and from those a projection of
recordings per hour at 16 and 128 workers, with what would limit it. Also the CPU each
took (getrusage: the serial loop's process; the cluster's client and scheduler, and its
workers once reaped): on a machine shared with other work the wall ratio follows the
other work's load, while the CPU the cluster spends beyond the serial loop's does not.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console

from shockdyno.batch.jobs import run_job
from shockdyno.batch.runner import dask_client, plan_jobs, run_batch
from shockdyno.run.plan import SweepPlan
from shockdyno.run.recording import record_sweep
from shockdyno.simrig import start_sim_rig

ROOT = Path(__file__).resolve().parents[1]
SIM_RIG = ROOT / "rigs" / "sim.toml"
# Four clicks x three frequencies: a fit of about 2 s here (an imported two-test file
# fits in 0.5 s, where the cluster's start and the overhead are the story, not the fits).
PLAN = SweepPlan(
    clicks=(0, 7, 14, 21), frequencies_hz=(0.5, 1.0, 1.5), warmup_cycles=1, measured_cycles=2
)


def make_recordings(folder: Path, n: int) -> list[Path]:
    out = []
    for i in range(n):
        path = folder / f"rec{i:03d}.mcap"
        with (
            start_sim_rig(SIM_RIG, speed=100, seed=1000 + i) as sim,
            contextlib.redirect_stdout(io.StringIO()),  # the live view's plain lines
        ):
            record_sweep(sim.rig_config(), PLAN, path, metadata={"damper_id": f"B{i:03d}"},
                         console=Console(quiet=True))  # fmt: skip
        out.append(path)
    return out


def noop(_: int) -> int:
    return 0


def task_overhead(workers: int, n: int = 400) -> float:
    """Seconds per task of submitting, running and gathering a task that does nothing."""
    from distributed import wait

    with dask_client(None, workers) as client:
        client.gather(client.map(noop, range(20), pure=False))  # warm
        t0 = time.perf_counter()
        wait(client.map(noop, range(n), pure=False))
        return (time.perf_counter() - t0) / n


ONE_THREAD = {k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}


def serial_seconds(recs: list[Path], out: Path) -> float:
    out.mkdir(parents=True, exist_ok=True)
    jobs = plan_jobs("fit", recs, out, {"seed": 0})
    t0 = time.perf_counter()
    rows = [run_job(j) for j in jobs]
    assert all(r.status == "done" for r in rows), rows
    return time.perf_counter() - t0


def cpu_seconds() -> tuple[float, float]:
    """CPU (user + sys) of this process and of its reaped children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, kids.ru_utime + kids.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=24)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--serial-only", type=Path, help=argparse.SUPPRESS)  # the 1-thread child
    args = ap.parse_args()
    if args.serial_only is not None:
        recs = sorted(args.serial_only.glob("*.mcap"))
        print(serial_seconds(recs, args.serial_only / "out-1t"))
        return
    tmp = Path(tempfile.mkdtemp(prefix="bench-batch-"))
    try:
        t0 = time.perf_counter()
        recs = make_recordings(tmp / "in", args.recordings)
        size_mb = sum(r.stat().st_size for r in recs) / len(recs) / 1e6
        print(
            f"{len(recs)} recordings ({PLAN.clicks} clicks x 0.5/1/1.5 Hz, {size_mb:.2f} MB "
            f"each) made in {time.perf_counter() - t0:.0f} s; {os.cpu_count()} cpus, load "
            f"average {os.getloadavg()[0]:.1f}"
        )
        own0 = cpu_seconds()[0]
        serial = serial_seconds(recs, tmp / "serial")
        serial_cpu = cpu_seconds()[0] - own0
        per_task = serial / len(recs)
        # The same serial loop with one BLAS thread, as each Dask worker runs (distributed
        # sets OMP/OPENBLAS/MKL_NUM_THREADS=1 in its workers): the plain loop above already
        # spreads the fit's linear algebra over both cores.
        child = subprocess.run(
            [sys.executable, __file__, "--serial-only", str(tmp / "in")],
            env={**os.environ, **ONE_THREAD},
            capture_output=True,
            text=True,
            check=True,
        )
        serial_1t = float(child.stdout.strip().splitlines()[-1])

        started: list[float] = []
        cluster_out = tmp / "cluster"
        jobs = plan_jobs("fit", recs, cluster_out, {"seed": 0})
        cpu0 = cpu_seconds()
        t0 = time.perf_counter()
        rows = run_batch(
            jobs,
            cluster_out,
            workers=args.workers,
            on_cluster=lambda _: started.append(time.perf_counter()),
        )
        total = time.perf_counter() - t0
        cpu1 = cpu_seconds()  # the cluster is closed: its workers are reaped
        client_cpu, workers_cpu = cpu1[0] - cpu0[0], cpu1[1] - cpu0[1]
        assert all(r.status == "done" for r in rows), rows
        run_s = time.perf_counter() - started[0]
        overhead = task_overhead(args.workers)

        print(
            f"serial (baseline, same run): {serial:.1f} s, {per_task:.2f} s per recording; "
            f"with one BLAS thread {serial_1t:.1f} s"
        )
        print(
            f"LocalCluster {args.workers} workers: {total:.1f} s with the cluster's start, "
            f"{run_s:.1f} s from its start; throughput {serial / total:.2f}x serial "
            f"({serial / run_s:.2f}x without the start; aim >= 1.7x); against the one-thread "
            f"serial loop {serial_1t / total:.2f}x ({serial_1t / run_s:.2f}x without the start)"
        )
        cluster_cpu = client_cpu + workers_cpu
        print(
            f"CPU: serial {serial_cpu:.1f} s; cluster {cluster_cpu:.1f} s (client and "
            f"scheduler {client_cpu:.1f} s, workers {workers_cpu:.1f} s), "
            f"{cluster_cpu / serial_cpu:.2f}x the serial loop's for the same fits"
        )
        print(f"per-task scheduling overhead (no-op round trip): {overhead * 1e3:.2f} ms")
        for n in (16, 128):
            ideal = 3600 * n / (per_task + overhead)
            sched_cap = 3600 / overhead
            print(
                f"projection at {n} workers: {min(ideal, sched_cap):.0f} recordings/h "
                f"({n} x 3600 / ({per_task:.2f} s + {overhead * 1e3:.1f} ms)); the scheduler "
                f"alone would pass {sched_cap:.0f}/h"
            )
        print(
            "what limits it: below ~1000 workers not the scheduler (one task per recording, "
            "seconds each, against a sub-ms overhead per task); reading recordings "
            f"({size_mb:.2f} MB each, once for the hash on the client and once on a worker) "
            "needs shared storage with ~2 MB/s per worker at these sizes; the results table "
            "is rewritten whole at most once a second, O(rows) each time, so 100 000 rows "
            "cost ~1 s a rewrite: past that, write it at the end only"
        )
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
