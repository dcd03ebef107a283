"""Per-test and per-module CPU of a pytest run: a plugin passed with `-p`, no conftest.

    PYTHONPATH=benchmarks SUITE_CPU_OUT=/tmp/cpu .venv/bin/pytest -p suite_cpu ...
    .venv/bin/python benchmarks/suite_cpu.py /tmp/cpu        # the tables

Each process (the controller and every xdist worker) writes one JSON file into
$SUITE_CPU_OUT: user+sys CPU from getrusage of the process and of its reaped children,
taken around each test's setup, call and teardown (a module's fixtures are charged to
the test that sets them up or tears them down), and the process's totals at the end
(collection and imports included). A child still running when a test ends is charged to
the test in which it is reaped.
"""

from __future__ import annotations

import json
import os
import resource
import sys
import time
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest


def _cpu() -> float:
    s = resource.getrusage(resource.RUSAGE_SELF)
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


_tests: dict[str, list[float]] = {}
_start = (_cpu(), time.monotonic())


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: Any) -> Iterator[None]:
    cpu, wall = _cpu(), time.monotonic()
    yield
    _tests[item.nodeid] = [_cpu() - cpu, time.monotonic() - wall]


def pytest_sessionfinish(session: pytest.Session) -> None:
    out = os.environ.get("SUITE_CPU_OUT")
    if not out:
        return
    name = os.environ.get("PYTEST_XDIST_WORKER", "main")
    Path(out).mkdir(parents=True, exist_ok=True)
    total = {"cpu": _cpu() - _start[0], "wall": time.monotonic() - _start[1]}
    body = {"worker": name, "total": total, "tests": _tests}
    (Path(out) / f"{name}.json").write_text(json.dumps(body))


def _table(folder: Path, top: int) -> None:
    modules: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0])
    tests: dict[str, list[float]] = {}
    for f in sorted(folder.glob("*.json")):
        body = json.loads(f.read_text())
        t = body["total"]
        print(f"{body['worker']:>6}: process+children {t['cpu']:8.1f} s CPU, {t['wall']:7.1f} s")
        for nodeid, (cpu, wall) in body["tests"].items():
            tests[nodeid] = [cpu, wall]
            m = modules[nodeid.split("::", 1)[0]]
            m[0] += cpu
            m[1] += wall
            m[2] += 1
    total = sum(m[0] for m in modules.values())
    print(f"tests: {len(tests)}, their CPU {total:.1f} s")
    print(f"\n{'module':<58}{'tests':>6}{'CPU s':>9}{'wall s':>9}")
    for name, (cpu, wall, n) in sorted(modules.items(), key=lambda kv: -kv[1][0])[:top]:
        print(f"{name:<58}{n:>6}{cpu:>9.1f}{wall:>9.1f}")
    print(f"\n{'test':<90}{'CPU s':>8}{'wall s':>8}")
    for nodeid, (cpu, wall) in sorted(tests.items(), key=lambda kv: -kv[1][0])[: top * 2]:
        print(f"{nodeid[:89]:<90}{cpu:>8.1f}{wall:>8.1f}")


if __name__ == "__main__":
    _table(Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 25)
