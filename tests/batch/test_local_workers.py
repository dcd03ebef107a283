"""The batch's local workers (batch/local.py), real processes: a task that raises is its
item's exception; a worker that dies under a task has the task run again on a new worker,
and after ALLOWED_FAILURES deaths the item is reported, not the batch ended; no process
outlives the pool. Forked from a one-thread process, spawned from one with threads."""

from __future__ import annotations

import os
import sys
import threading

import psutil
import pytest

from shockdyno.batch import local
from shockdyno.batch.local import ALLOWED_FAILURES, LocalWorkers, WorkerDied


def _task(x: object) -> object:
    if x == "raise":
        raise ValueError("bad item")
    if x == "die":
        os._exit(9)  # as a worker killed under its task
    if x == "warm":
        return "shockdyno_warmed" in sys.modules  # what the parent loaded before the fork
    assert isinstance(x, int)
    return x * 2


def _children() -> list[psutil.Process]:
    return [p for p in psutil.Process().children(recursive=True) if p.status() != "zombie"]


def _warm() -> None:
    sys.modules["shockdyno_warmed"] = sys  # any module object: a marker the fork inherits


def test_results_errors_and_a_worker_that_keeps_dying(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delitem(sys.modules, "shockdyno_warmed", raising=False)
    deaths: list[int] = []
    real = local._Worker

    def counted(*args: object) -> local._Worker:
        deaths.append(1)
        return real(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(local, "_Worker", counted)
    items: list[object] = [1, "raise", "die", 3, "warm"]
    before = {p.pid for p in _children()}
    with LocalWorkers(_task, 2, warm=_warm) as pool:
        assert pool.start_method == "fork"  # this test process runs one thread
        assert len(_children()) == len(before) + 2
        got = dict((str(item), out) for item, out in pool.results(items))
    assert got["1"] == 2 and got["3"] == 6 and got["warm"] is True
    assert isinstance(got["raise"], ValueError) and "bad item" in str(got["raise"])
    assert isinstance(got["die"], WorkerDied) and "died 3 times" in str(got["die"])
    assert len(deaths) == 2 + ALLOWED_FAILURES  # each death replaced its worker
    assert {p.pid for p in _children()} == before  # every worker stopped and reaped


def test_with_another_thread_running_the_workers_are_spawned() -> None:
    before = {p.pid for p in _children()}
    stop = threading.Event()
    other = threading.Thread(target=stop.wait, daemon=True)
    other.start()
    try:
        with LocalWorkers(_task, 2, warm=_warm) as pool:
            assert pool.start_method == "spawn"  # a fork would inherit its locks
            got = sorted(out for _, out in pool.results([1, 2, 3]))  # type: ignore[type-var]
    finally:
        stop.set()
        other.join()
    assert got == [2, 4, 6]
    assert {p.pid for p in _children()} == before
