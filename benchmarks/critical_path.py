"""The critical path of one `diagnose --workers N` in CPU seconds, which a loaded machine
does not blur as it does wall time (issue 44: a 15-test sweep diagnosed in 30 s on an
idle 2-core machine).

On N idle cores the diagnosis's wall time is about: the CPU of what the diagnosing process
does itself (the baseline fit, each round's null refit, the decisions, the final refit and
the description: the serial stages, while the workers wait), plus, for each map of
independent refits the workers run (workers.py: a round's candidates, held-out folds, ...),
the time the last of them finishes when the items go, in order, to whichever of N workers
is free first (each item's CPU measured in the worker). Printed: each map (its items' CPU,
that finishing time), the serial stages' CPU, their sum (the critical path), the total CPU
(the process and its workers) and the load average, which inflates every CPU figure too
(cache and memory shared with other work): compare runs made side by side.

    .venv/bin/python benchmarks/critical_path.py REC.mcap [--workers 2] [--json DIAG.json]

Run it with another checkout's Python (/work/main/.venv/bin/python) to measure that one:
it only wraps `Workers.map`, which each has.
"""

from __future__ import annotations

import argparse
import heapq
import json
import os
import resource
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

MAPS: list[tuple[str, list[float], float]] = []  # (function, item CPU, this process's CPU)


def timed(shared: tuple[Callable[[Any, Any], Any], Any], item: Any) -> tuple[Any, float]:
    """An item run as it would be, with the CPU it took in the process that ran it."""
    fn, inner = shared
    t = time.process_time()
    out = fn(inner, item)
    return out, time.process_time() - t


def finish(costs: Sequence[float], n: int) -> float:
    """When the last item ends, each given in order to the first free of n workers."""
    free = [0.0] * n
    for c in costs:
        heapq.heappush(free, heapq.heappop(free) + c)
    return max(free)


def wrap_maps() -> None:
    from shockdyno.diagnose import workers

    plain = workers.Workers.map

    def map_(self: Any, fn: Any, shared: Any, items: Sequence[Any], done: Any = None) -> list[Any]:
        t0 = time.process_time()
        got = plain(self, timed, (fn, shared), items, done)
        MAPS.append((fn.__name__, [c for _, c in got], time.process_time() - t0))
        return [r for r, _ in got]

    workers.Workers.map = map_  # type: ignore[method-assign]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recording", type=Path)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", type=Path, help="write DIAG.json here (as diagnose --json)")
    args = ap.parse_args(argv)
    # Loaded before the clock, as diag_equal does (diagnose_file imports them inside).
    import shockdyno.diagnose.engine
    import shockdyno.diagnose.verdict  # noqa: F401
    from shockdyno import schema
    from shockdyno.diagnose.file import diagnose_file

    wrap_maps()
    r0 = resource.getrusage(resource.RUSAGE_SELF)
    t0, w0 = time.process_time(), time.perf_counter()
    _, doc = diagnose_file(args.recording, workers=args.workers)
    own = time.process_time() - t0
    wall = time.perf_counter() - w0
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    done = resource.getrusage(resource.RUSAGE_CHILDREN)  # the workers, ended with it
    children = done.ru_utime + done.ru_stime
    if args.json is not None:
        args.json.write_text(json.dumps(schema.to_json(doc), indent=2, sort_keys=True))
    n = max(args.workers, 1)
    serial = own - sum(m[2] for m in MAPS)
    path = serial
    for name, costs, _ in MAPS:
        if not costs:
            continue
        ends = finish(costs, n) if len(costs) > 1 else costs[0]
        path += ends
        print(f"map {name:14s} {len(costs):3d} items, CPU {sum(costs):6.2f} s, ends {ends:6.2f} s")
    print(
        f"serial stages {serial:.2f} s CPU; critical path {path:.2f} s; total CPU "
        f"{own + children:.2f} s (this process {own:.2f}, workers {children:.2f}); "
        f"wall {wall:.1f} s at load {os.getloadavg()[0]:.1f}"
    )
    # A fork shares the pages: whichever process writes one first copies it (a fault).
    print(
        f"this process: system CPU {r1.ru_stime - r0.ru_stime:.2f} s, "
        f"{r1.ru_minflt - r0.ru_minflt} page faults; workers: system CPU {done.ru_stime:.2f} s, "
        f"{done.ru_minflt} page faults"
    )


if __name__ == "__main__":
    main()
