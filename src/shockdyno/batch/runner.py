"""Run many recordings: on local worker processes by default, or on a Dask scheduler.

One recording is one task (`jobs.run_job`). Locally, the tasks run on processes forked
from this one (batch/local.py); with `--scheduler`, on Dask distributed, submitted with
`pure=False`. Either way a task whose worker dies is run again on another worker (locally
batch/local.ALLOWED_FAILURES, on Dask its `allowed_failures`). The results table is
rewritten, atomically, each time a task finishes, so Ctrl-C or a lost scheduler leaves
every finished result and a readable table of them (rewritten at most once a second while
results arrive, and at the end).
"""

from __future__ import annotations

import glob
import hashlib
import logging
import math
import time
from collections.abc import Callable, Generator, Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from shockdyno.batch.jobs import Job, Options, run_job, warm_up
from shockdyno.batch.local import LocalWorkers
from shockdyno.batch.table import Row, earlier_rows, merged, write_table
from shockdyno.diagnose.workers import usable_cores
from shockdyno.errors import ConfigError, ShockdynoError
from shockdyno.history import record_result_file
from shockdyno.record.identity import recording_sha256

if TYPE_CHECKING:  # for the types only: distributed is imported when a batch runs on it
    from distributed import Client

Progress = Callable[[Row, int, int], None]
T = TypeVar("T")
R = TypeVar("R")
# The table is rewritten whole: at most this often while results arrive (thousands of rows
# rewritten per result would be quadratic), and always at the end, Ctrl-C included.
TABLE_EVERY_S = 1.0


def collect(paths: Sequence[str]) -> list[Path]:
    """Recordings named, in folders (recursively) or matched by globs; sorted, unique.
    Part files of a recording set (NAME.part2.mcap) are the set's, not recordings."""
    found: list[Path] = []
    for text in paths:
        p = Path(text)
        if p.is_dir():
            found += sorted(p.rglob("*.mcap"))
        elif any(c in text for c in "*?["):
            found += sorted(Path(m) for m in glob.glob(text, recursive=True))
        elif p.exists():
            found.append(p)
        else:
            raise ConfigError(f"no such recording, folder or match: {text}")
    out = [p for p in dict.fromkeys(found) if ".part" not in p.name and not p.name.startswith(".")]
    if not out:
        raise ConfigError(f"no recordings in {', '.join(paths)}")
    return out


def plan_jobs(kind: str, recordings: Iterable[Path], out_dir: Path, options: Options) -> list[Job]:
    """A job per recording; names are the file stems, made unique with the path's hash."""
    recs = list(recordings)
    stems = [r.name.removesuffix(".mcap") for r in recs]
    jobs = []
    for rec, stem in zip(recs, stems, strict=True):
        try:
            sha = recording_sha256(rec)
        except Exception as exc:  # unreadable: the task will say so in its row
            sha = f"unreadable: {exc}"
        name = stem
        if stems.count(stem) > 1:
            name = f"{stem}-{hashlib.sha256(str(rec.resolve()).encode()).hexdigest()[:8]}"
        jobs.append(Job(kind, str(rec), name, sha, str(out_dir), options.copy()))
    return jobs


def _client(scheduler: str) -> Client:
    # Dask is imported when a batch runs on a scheduler: +300 ms CPU (distributed) and
    # +70 ms (dask) at every command's start-up otherwise (measured).
    from distributed import Client

    try:
        return Client(scheduler, timeout="10s")  # type: ignore[no-untyped-call]
    except OSError as exc:
        raise ConfigError(f"--scheduler {scheduler}: cannot connect ({exc})") from None


@contextmanager
def dask_client(scheduler: str) -> Iterator[Client]:
    """A client of the Dask scheduler at `scheduler`; closed at the end."""
    logging.getLogger("distributed").setLevel(logging.ERROR)  # its shutdown chatter
    client = _client(scheduler)
    try:
        yield client
    finally:
        client.close()  # type: ignore[no-untyped-call]


def map_tasks(
    fn: Callable[[T], R],
    items: Sequence[T],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    on_cluster: Callable[[str], None] | None = None,
    warm: Callable[[], None] | None = None,
) -> Generator[tuple[T, R | BaseException], None, None]:
    """fn(item) for every item, each a task, yielded as they finish: (item, result) or
    (item, the exception). On `workers` local processes (default: the cores this process
    may run on; never more than there are items), or on the Dask scheduler at
    `scheduler`. A task whose worker dies is run again elsewhere. `on_cluster` is told
    where the tasks run once the workers are up. `warm` (local workers only) is run in
    this process before they are forked from it. `fn` is a module-level function. The
    benchmarks run their recordings through this too, so they can use a cluster."""
    if scheduler:
        yield from _on_dask(fn, items, scheduler, on_cluster)
        return
    n = max(1, min(workers or usable_cores(), len(items)))
    with LocalWorkers(fn, n, warm) as pool:
        if on_cluster is not None:
            on_cluster(f"{n} local worker process{'es' if n > 1 else ''}")
        yield from pool.results(items)


def _on_dask(
    fn: Callable[[T], R],
    items: Sequence[T],
    scheduler: str,
    on_cluster: Callable[[str], None] | None,
) -> Iterator[tuple[T, R | BaseException]]:
    from distributed import as_completed  # +300 ms at start-up, as in _client

    with dask_client(scheduler) as client:
        if on_cluster is not None:
            on_cluster(f"{scheduler}; dashboard {client.dashboard_link or 'none'}")
        futures = {
            client.submit(fn, item, pure=False, key=f"task-{i}-{id(item):x}"): item
            for i, item in enumerate(items)
        }
        try:
            for future in as_completed(futures):  # type: ignore[no-untyped-call]
                try:
                    yield futures[future], future.result()
                except Exception as exc:  # the task raised, or its workers kept dying
                    yield futures[future], exc
        finally:
            # Release every task before the client goes: nothing is left to recompute.
            client.cancel(list(futures))  # type: ignore[no-untyped-call]
            futures.clear()


def run_batch(
    jobs: list[Job],
    out_dir: Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    on_cluster: Callable[[str], None] | None = None,
    history: Path | None = None,
    warn: Callable[[str], None] | None = None,
) -> list[Row]:
    """Run every job; returns this run's rows. out_dir/results.parquet and .csv hold them
    with the rows of earlier runs whose (name, kind) this run did not touch. With
    `history`, each fit and diagnosis (done, or skipped as done before) is added to that
    database here, in this one process, as its task finishes: the workers never write it
    (one writer; an SQLite file on a cluster's shared storage is no place for many)."""
    earlier = earlier_rows(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows: dict[str, Row] = {}
    last_write = -math.inf
    kinds = {j.kind for j in jobs}
    tasks = map_tasks(run_job, jobs, scheduler=scheduler, workers=workers, on_cluster=on_cluster,
                      warm=lambda: warm_up(kinds))  # fmt: skip
    try:
        for job, got in tasks:
            if isinstance(got, BaseException):
                row = Row(job.recording, job.name, job.sha256, job.kind, "failed")
                row.error = f"{type(got).__name__}: {' '.join(str(got).split())[:300]}"
            else:
                row = got
                if history is not None and row.status in ("done", "skipped"):
                    _keep(history, job, row, warn)
            rows[job.name] = row
            now = time.monotonic()
            if now - last_write >= TABLE_EVERY_S:
                write_table(out_dir, merged(earlier, _ordered(rows, jobs)))
                last_write = now
            if progress is not None:
                progress(row, len(rows), len(jobs))
    finally:
        tasks.close()  # the workers stopped (a Ctrl-C's too) before the last table
        write_table(out_dir, merged(earlier, _ordered(rows, jobs)))
    return _ordered(rows, jobs)


def _keep(history: Path, job: Job, row: Row, warn: Callable[[str], None] | None) -> None:
    o = job.options
    try:
        record_result_file(
            history,
            Path(job.recording),
            job.kind,
            job.result_path,
            alpha=o.get("alpha", 0.01),
            seed=o.get("seed", 0),
            terms=o.get("terms", "all"),
        )
    except (ShockdynoError, OSError) as exc:  # the result stands; the history says why not
        if warn is not None:
            warn(f"history not updated for {row.name}: {exc}")


def _ordered(rows: dict[str, Row], jobs: list[Job]) -> list[Row]:
    return [rows[j.name] for j in jobs if j.name in rows]
