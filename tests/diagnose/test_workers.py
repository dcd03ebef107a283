"""The search's refits in worker processes (diagnose/workers.py): the same diagnosis as
one after another, only on more cores."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.verdict import to_json
from shockdyno.diagnose.workers import Workers
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.spec import load_spec


def _square_after(shared: float, x: float) -> tuple[float, int]:
    time.sleep(shared * (3 - x))  # the first items finish last
    return x * x, os.getpid()


def _fails(shared: None, x: int) -> int:
    if x == 2:
        raise ValueError(f"item {x} is bad")
    return x


def test_results_come_back_in_the_items_order_from_other_processes() -> None:
    done: list[int] = []
    with Workers(2) as w:
        got = w.map(_square_after, 0.2, [0.0, 1.0, 2.0, 3.0], done.append)
        assert w.start_method == "fork"  # this process runs one thread
    assert [g[0] for g in got] == [0.0, 1.0, 4.0, 9.0]
    assert sorted(done) == [0, 1, 2, 3]
    assert os.getpid() not in {g[1] for g in got}  # not run here


LOADED = "at import"


def _loaded(shared: None, x: int) -> tuple[str, int]:
    return LOADED, os.getpid()


def test_forked_at_the_first_map_they_inherit_what_was_loaded_before_it() -> None:
    # Forked at the start, each worker loaded again what the baseline fit loaded here
    # (scipy's optimisers, the numba kernels) in its first refit.
    global LOADED
    with Workers(2) as w:
        assert w.start_method == "fork" and not multiprocessing.active_children()
        LOADED = "after the start"
        try:
            got = w.map(_loaded, None, [0, 1, 2])
        finally:
            LOADED = "at import"
        assert len(multiprocessing.active_children()) == 2
    assert [g[0] for g in got] == ["after the start"] * 3
    assert os.getpid() not in {g[1] for g in got}


def test_with_another_thread_running_they_come_from_a_fork_server() -> None:
    # A thread (a progress bar's refresh) could hold a lock a fork would inherit held.
    stop = threading.Event()
    t = threading.Thread(target=stop.wait, daemon=True)
    t.start()
    try:
        with Workers(2) as w:
            got = w.map(_square_after, 0.0, [2.0, 3.0])
            method = w.start_method
    finally:
        stop.set()
        t.join(5)
    assert method == "forkserver"
    assert [g[0] for g in got] == [4.0, 9.0] and os.getpid() not in {g[1] for g in got}


def test_one_worker_runs_here() -> None:
    with Workers(1) as w:
        got = w.map(_square_after, 0.0, [1.0, 2.0])
    assert {g[1] for g in got} == {os.getpid()}


def test_a_worker_error_reaches_the_caller() -> None:
    with Workers(2) as w, pytest.raises(ValueError, match="item 2 is bad"):
        w.map(_fails, None, [0, 1, 2, 3])


def _pool_in_daemon(q: multiprocessing.Queue) -> None:  # type: ignore[type-arg]
    with Workers(2) as w:
        q.put(w.map(_square_after, 0.0, [1.0, 2.0])[0][1] == os.getpid())


def test_a_daemonic_process_runs_them_itself() -> None:
    # A Dask worker is daemonic and may not have children: the items run in it.
    ctx = multiprocessing.get_context("spawn")
    q = ctx.Queue()
    p = ctx.Process(target=_pool_in_daemon, args=(q,), daemon=True)
    p.start()
    assert q.get(timeout=60) is True
    p.join(10)


def test_the_diagnosis_is_the_same_with_two_workers() -> None:
    tests = synthetic_sweep(load_spec(None), [15], cycles=4, seed=7, force_delay_s=0.004)
    s = Settings(
        candidates=("sensor_lag", "friction", "thermal"), calibrations=(), max_terms=1, n_boot=199
    )
    docs = []
    for n in (1, 2):
        doc = to_json(diagnose(tests, settings=s, workers=n))
        doc["info"].pop("wall_s")
        docs.append(json.dumps(doc, sort_keys=True))
    found = json.loads(docs[0])["findings"]
    # Refits in the workers: three candidates, and the claimed one's folds (a round scores
    # held out only the candidates whose gain decides something: claims.Judge.score_heldout).
    assert len(found) == 3
    assert any(f["claimed"] and f["heldout_gain"] is not None for f in found)
    assert docs[1] == docs[0]


WORKERS_THEN_HANG = """
import os, signal, sys, time
from shockdyno.diagnose.workers import Workers

signal.signal(signal.SIGINT, signal.default_int_handler)  # a shell's background job ignores it

def pid(shared, x):
    time.sleep(0.2)  # both workers take one
    return os.getpid()

def hang(shared, x):
    time.sleep(600)

if __name__ == "__main__":
    with Workers(2) as w:
        print(*set(w.map(pid, None, [0, 1, 2, 3])), flush=True)
        w.map(hang, None, [0, 1])
"""


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split()[2] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="prctl is Linux's")
@pytest.mark.parametrize("how", ["SIGKILL", "Ctrl-C"])
def test_workers_end_when_the_diagnosis_is_stopped(how: str, tmp_path: Path) -> None:
    script = tmp_path / "hang.py"
    script.write_text(WORKERS_THEN_HANG)
    cmd = [sys.executable, str(script)]
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, start_new_session=True) as p:
        assert p.stdout is not None
        pids = [int(x) for x in p.stdout.readline().split()]
        assert pids and all(_alive(q) for q in pids)
        if how == "SIGKILL":
            p.kill()  # no handler runs, no `with` exits: the workers see their parent go
        else:
            os.killpg(p.pid, signal.SIGINT)  # a terminal's Ctrl-C reaches the whole group
        p.wait(10)
    deadline = time.monotonic() + 10
    while any(_alive(q) for q in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(q) for q in pids)
