"""`shockdyno batch` on 2 local worker processes (one of them killed while it holds a task;
the batch stopped by SIGINT and SIGTERM mid-run) and on a real Dask cluster: a `dask
scheduler` with two `dask worker` processes on 127.0.0.1, one of them killed while it
holds a task. The batch's JSONs equal the single command's (wall time aside); a
bad recording is a row with its error; a re-run skips what is done."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from inprocess import cli
from shockdyno.batch.table import read_table
from shockdyno.cli import main

REPO = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-m", "shockdyno.cli"]
MANIFEST = REPO / "recordings" / "examples" / "csv" / "manifest.csv"
pytestmark = [pytest.mark.timeout(240), pytest.mark.slow]  # clusters of processes: about 1 min


def _cli(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*CLI, *args], capture_output=True, text=True, timeout=200, cwd=REPO, env=env
    )


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Four small recordings (one damper id each), a foreign file and a cut-off one."""
    root = tmp_path_factory.mktemp("batch-in")
    for i in range(4):  # in this process: a `shockdyno` process costs a second to start
        argv = ["import", str(MANIFEST), "-o", str(root / f"r{i}.mcap"), "--meta"]
        assert main([*argv, f"damper_id=D{i}"]) == 0
    (root / "bad.mcap").write_text("not a recording\n")
    data = (root / "r0.mcap").read_bytes()
    (root / "cut.mcap").write_bytes(data[:200])  # the header and nothing more
    return root


def _without_wall(doc: dict) -> dict:  # type: ignore[type-arg]
    doc = json.loads(json.dumps(doc))
    doc["info"].pop("wall_s", None)
    return doc


def test_a_local_cluster_batch_is_the_single_command_and_resumes(
    recordings: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    done = _cli("batch", "fit", str(recordings), "--out", str(out), "--workers", "2")
    assert done.returncode == 3, done.stderr  # the two bad files failed; the rest ran
    rows = {r.name: r for r in read_table(out)}
    assert set(rows) == {"r0", "r1", "r2", "r3", "bad", "cut"}
    for name in ("r0", "r1", "r2", "r3"):
        assert rows[name].status == "done" and rows[name].clicks == "0,21"
        assert json.loads((out / f"{name}.fit.json").read_text())["tests"]
    # The four differ only in their damper id: the first and the last against the single
    # command (each single fit is seconds of CPU on a suite that is CPU-bound).
    for name in ("r0", "r3"):
        single = tmp_path / f"{name}.json"
        assert main(["fit", str(recordings / f"{name}.mcap"), "--json", str(single)]) == 0
        batch_doc = json.loads((out / f"{name}.fit.json").read_text())
        assert _without_wall(batch_doc) == _without_wall(json.loads(single.read_text()))
    for name in ("bad", "cut"):
        assert rows[name].status == "failed"
        assert rows[name].error and "\n" not in rows[name].error
    assert "not an MCAP file" in rows["bad"].error
    csv = (out / "results.csv").read_text().splitlines()
    assert len(csv) == 7 and csv[0].startswith('"path","name","sha256"')
    assert [rows[f"r{i}"].damper_id for i in range(4)] == ["D0", "D1", "D2", "D3"]
    # A re-run skips every result made from the same bytes, options and version.
    mtimes = {p.name: p.stat().st_mtime_ns for p in out.glob("*.fit.json")}
    again = _cli("batch", "fit", str(recordings), "--out", str(out), "--workers", "2")
    assert again.returncode == 3
    rows = {r.name: r for r in read_table(out)}
    assert [rows[f"r{i}"].status for i in range(4)] == ["skipped"] * 4
    assert [rows[f"r{i}"].damper_id for i in range(4)] == ["D0", "D1", "D2", "D3"]
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.fit.json")} == mtimes
    # Other options are another result: not skipped. In this process, as a caller would:
    # the workers forked from it are all gone when the call returns.
    before = _children()
    other = main(["batch", "fit", str(recordings / "r0.mcap"), "--out", str(out), "--workers",
                  "2", "--terms", "none"])  # fmt: skip
    assert other == 0
    assert _children() == before
    rows = {r.name: r.status for r in read_table(out)}
    assert rows["r0"] == "done" and rows["r1"] == "skipped"  # the others' rows are kept
    # The README's second command into the same folder (issue 47.2: it rewrote the table
    # with its own rows): the fit rows stay, the diagnose row joins them, both with the
    # recording's damper id (issue 47.3: empty in fit and diagnose rows).
    diag = _cli("batch", "diagnose", str(recordings / "r1.mcap"), "--out", str(out), "--fit",
                str(out), "--workers", "1")  # fmt: skip
    assert diag.returncode == 0, diag.stderr
    assert "(with 6 rows of earlier runs)" in diag.stdout
    rows = read_table(out)
    assert [(r.name, r.kind) for r in rows] == [
        ("bad", "fit"), ("cut", "fit"), ("r0", "fit"), ("r1", "fit"), ("r1", "diagnose"),
        ("r2", "fit"), ("r3", "fit"),
    ]  # fmt: skip
    assert [r.damper_id for r in rows if r.name == "r1"] == ["D1", "D1"]
    assert rows[4].status == "done" and rows[4].e_t_before is not None
    csv = (out / "results.csv").read_text().splitlines()
    assert len(csv) == 8 and '"r1","' in csv[5] and '"diagnose"' in csv[5]
    assert "no NAME.fit.json" not in diag.stderr
    # A recording the --fit folder has no fit of runs without one, and the batch says so
    # before it starts (it ran silently without the fit).
    nofit = _cli("batch", "diagnose", str(recordings / "cut.mcap"), "--out",
                 str(tmp_path / "other"), "--fit", str(out), "--workers", "1")  # fmt: skip
    assert nofit.returncode == 3, nofit.stderr
    warned = [line for line in nofit.stderr.splitlines() if "no NAME.fit.json" in line]
    assert len(warned) == 1 and "for 1 of 1 recordings (cut): they run without a fit" in warned[0]


def test_a_damaged_results_table_is_refused_before_any_work(
    recordings: Path, tmp_path: Path
) -> None:
    out = tmp_path / "results"
    out.mkdir()
    (out / "results.parquet").write_bytes(b"PAR1 torn")
    # In this process: refused before any worker starts (what it says and leaves).
    done = cli("batch", "fit", str(recordings / "r0.mcap"), "--out", str(out))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "results.parquet cannot be read" in done.stderr
    assert (out / "results.parquet").read_bytes() == b"PAR1 torn"
    assert sorted(p.name for p in out.iterdir()) == ["results.parquet"]


def _children(pid: int | None = None) -> set[int]:
    """The live processes under this one (or pid), zombies aside."""
    kids = psutil.Process(pid).children(recursive=True)
    return {p.pid for p in kids if _alive(p)}


def _alive(p: psutil.Process) -> bool:
    try:
        return p.is_running() and p.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_stopped_batch_leaves_no_process_and_every_finished_row(
    recordings: Path, tmp_path: Path, sig: signal.Signals
) -> None:
    out = tmp_path / "out"
    # Each worker's first task waits 2 s first: both are busy when the signal comes.
    env = {**os.environ, "SHOCKDYNO_BATCH_TEST_DELAY_S": "2"}
    paths = [str(recordings / n) for n in ("bad.mcap", "cut.mcap", "r0.mcap", "r1.mcap",
                                           "r2.mcap", "r3.mcap")]  # fmt: skip
    batch = subprocess.Popen(
        [*CLI, "batch", "fit", *paths, "--out", str(out), "--workers", "2"],
        cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        workers: set[int] = set()
        deadline = time.monotonic() + 120
        while not (out / "results.csv").exists():  # written as the first result arrives
            assert batch.poll() is None and time.monotonic() < deadline, batch.stderr
            workers |= _children(batch.pid)
            time.sleep(0.05)
        workers |= _children(batch.pid)
        assert len(workers) >= 2  # the two workers, seen while they worked
        batch.send_signal(sig)
        _, stderr = batch.communicate(timeout=60)
    finally:
        if batch.poll() is None:
            batch.kill()
            batch.wait()
    assert batch.returncode == 128 + sig, stderr
    name = "interrupted" if sig == signal.SIGINT else "stopped by SIGTERM"
    assert f"shockdyno batch: {name}" in stderr and "Traceback" not in stderr
    assert not [pid for pid in workers if psutil.pid_exists(pid) and _alive(psutil.Process(pid))]
    rows = {r.name: r.status for r in read_table(out)}
    assert rows and len(rows) < 6  # stopped mid-run, with what had finished
    said = re.findall(r"^batch: \d+/6 (\w+) (\w+)", stderr, re.M)  # its progress lines
    assert all(rows.get(name) == status for status, name in said)  # each one said is kept
    assert all(rows[n] == "done" for n in rows if n.startswith("r"))
    for p in out.glob("*.fit.json"):
        json.loads(p.read_text())  # whole, not torn


def test_a_killed_local_worker_has_its_task_run_again(recordings: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    env = {**os.environ, "SHOCKDYNO_BATCH_TEST_DELAY_S": "4"}
    paths = [str(recordings / f"r{i}.mcap") for i in range(3)]
    batch = subprocess.Popen(
        [*CLI, "batch", "fit", *paths, "--out", str(out), "--workers", "2", "--no-history"],
        cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while len(_children(batch.pid)) < 2:  # both workers are in their first task's wait
            assert batch.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        victim = min(_children(batch.pid))
        os.kill(victim, signal.SIGKILL)
        stdout, stderr = batch.communicate(timeout=180)
    finally:
        if batch.poll() is None:
            batch.kill()
            batch.wait()
    assert batch.returncode == 0, stderr
    assert "3 done" in stdout
    rows = read_table(out)
    assert [(r.name, r.status) for r in rows] == [("r0", "done"), ("r1", "done"), ("r2", "done")]
    for p in out.glob("*.fit.json"):
        json.loads(p.read_text())  # whole, not torn


def _start(cmd: list[str], env: dict[str, str]) -> subprocess.Popen[bytes]:
    return subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def test_a_scheduler_with_two_workers_survives_a_killed_worker(
    recordings: Path, tmp_path: Path
) -> None:
    sched_file = tmp_path / "scheduler.json"
    env = {**os.environ, "SHOCKDYNO_BATCH_TEST_DELAY_S": "5"}
    py = [sys.executable, "-m"]
    scheduler = _start(
        [*py, "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
         "--dashboard-address", "127.0.0.1:0", "--scheduler-file", str(sched_file)],
        env,
    )  # fmt: skip
    workers: list[subprocess.Popen[bytes]] = []
    try:
        deadline = time.monotonic() + 60
        while not sched_file.exists():
            assert time.monotonic() < deadline and scheduler.poll() is None
            time.sleep(0.1)
        time.sleep(0.2)
        address = json.loads(sched_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        for _ in range(2):
            workers.append(
                _start(
                    [
                        *py,
                        "distributed.cli.dask_worker",
                        address,
                        "--no-nanny",
                        "--nthreads",
                        "1",
                        "--host",
                        "127.0.0.1",
                        "--no-dashboard",
                    ],
                    env,
                )
            )
        out = tmp_path / "out"
        paths = [str(recordings / f"r{i}.mcap") for i in range(4)]
        batch = subprocess.Popen(
            [*CLI, "batch", "fit", *paths, "--out", str(out), "--scheduler", address],
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        time.sleep(3.5)  # both workers are inside their first task (each waits 5 s first)
        workers[0].send_signal(signal.SIGKILL)
        stdout, stderr = batch.communicate(timeout=180)
        assert batch.returncode == 0, stderr
        rows = read_table(out)
        assert sorted(r.name for r in rows) == ["r0", "r1", "r2", "r3"]
        assert all(r.status == "done" for r in rows)
        assert sorted(p.name for p in out.glob("*.fit.json")) == [
            f"r{i}.fit.json" for i in range(4)
        ]
        for p in out.glob("*.fit.json"):
            json.loads(p.read_text())  # whole, not torn
        assert "4 done" in stdout
    finally:
        for p in [*workers, scheduler]:
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
