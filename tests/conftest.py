"""Shared fixtures: the simulated rig over real transports, and the opt-in real rig.

Hardware tests run only with `pytest --rig rigs/<file>.toml`; without it they are skipped.
"""

from __future__ import annotations

import os
import sys
import threading
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[1]
SIM_RIG = REPO / "rigs" / "sim.toml"

# A test run keeps the bytecode it compiles, for itself, its workers and every process it
# starts: with PYTHONDONTWRITEBYTECODE set (as on some machines), each pytest worker
# rewrote every test module again at collection and each `shockdyno` a test starts
# compiled the project's sources again (the editable install leaves src/ uncompiled;
# benchmarks/results/suite9-2026-11-29.txt). The caches go into __pycache__ folders, which
# git ignores and where numba already keeps its kernels.
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
sys.dont_write_bytecode = False


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--rig",
        action="store",
        default=None,
        metavar="RIG_TOML",
        help="run hardware tests against the real rig described by this rig file",
    )


def _browser() -> Any:
    """tests/report/browser.py: where the browser tests find a Chromium already here."""
    import importlib.util

    name = "shockdyno_tests_browser"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, REPO / "tests/report/browser.py")
        assert spec is not None and spec.loader is not None
        sys.modules[name] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(sys.modules[name])
    return sys.modules[name]


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    _slow_modules_first(items)
    if config.getoption("--rig"):
        return
    skip = pytest.mark.skip(reason="needs a real rig: pytest --rig rigs/<file>.toml")
    for item in items:
        if "hardware" in item.keywords:
            item.add_marker(skip)


def _slow_modules_first(items: list[pytest.Item]) -> None:
    """The modules marked slow (a minute or more each, in a few tests) first, then the
    rest by their number of tests, most first. `make test` runs --dist loadscope with
    --no-loadscope-reorder, so the workers take modules in this order; xdist's own order
    (number of tests only) put the slow modules, two or three tests each, among the last
    (places 96-150 of 157), where a module of a minute can still run on one worker after
    the others have finished (benchmarks/results/suitebatch-2026-11-29.txt)."""

    def scope(item: pytest.Item) -> str:  # xdist's loadscope unit: a module, or a class
        return item.nodeid.rsplit("::", 1)[0]

    count = Counter(scope(item) for item in items)
    # A stable sort: each module keeps its own order.
    items.sort(key=lambda item: ("slow" not in item.keywords, -count[scope(item)]))


@pytest.fixture(autouse=True)
def _no_terminal_width(monkeypatch: pytest.MonkeyPatch) -> None:
    """pytest-xdist's workers (and some CI shells) set COLUMNS=80, which rich honours as a
    terminal's width and wraps a table's names; a test that means a width sets its own."""
    monkeypatch.delenv("COLUMNS", raising=False)


@pytest.fixture
def hardware_rig(request: pytest.FixtureRequest) -> Any:
    """The RigConfig of the real rig named by --rig (hardware tests only)."""
    from shockdyno.rig.config import load_rig

    path = request.config.getoption("--rig")
    if not path:
        pytest.skip("needs a real rig: pytest --rig rigs/<file>.toml")
    return load_rig(path)


@pytest.fixture
def sim_rig_factory() -> Iterator[Callable[..., Any]]:
    """Start simulated rigs (ephemeral ports); every one is closed at the end of the test."""
    from shockdyno.simrig import start_sim_rig

    started: list[Any] = []

    def start(**kwargs: Any) -> Any:
        kwargs.setdefault("speed", 20.0)
        sim = start_sim_rig(kwargs.pop("rig", SIM_RIG), **kwargs)
        started.append(sim)
        return sim

    yield start
    for sim in started:
        sim.close()


def open_fds() -> set[str]:
    """This process's open file descriptors that are sockets, pipes or ptys."""
    out: set[str] = set()
    for fd in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if target.startswith(("socket:", "/dev/pts", "/dev/ptmx", "anon_inode:[eventpoll]")):
            out.add(f"{fd}->{target}")
    return out


@pytest.fixture
def leak_check() -> Iterator[None]:
    """Fail if the test leaves a thread, socket, pty or event loop behind."""
    threads = set(threading.enumerate())
    fds = open_fds()
    yield
    extra_threads = [t for t in threading.enumerate() if t not in threads and t.is_alive()]
    assert not extra_threads, f"threads left behind: {extra_threads}"
    extra_fds = open_fds() - fds
    assert not extra_fds, f"descriptors left behind: {sorted(extra_fds)}"


def pytest_runtest_setup(item: pytest.Item) -> None:
    # The browser tests need a Chromium that is already on the machine (nothing is
    # installed): without one they skip from this one line, so the summary says it once.
    if "browser" in item.keywords and _browser().find_chromium() is None:
        pytest.skip(_browser().HOW_TO_ENABLE)


def pytest_configure(config: pytest.Config) -> None:
    # `fit`, `diagnose` and `batch` add to a history database (recordings/history.sqlite
    # by default, or $SHOCKDYNO_HISTORY): every test process gets its own, never the
    # checkout's nor the developer's.
    import shutil
    import tempfile

    folder = tempfile.mkdtemp(prefix="shockdyno-history-")
    os.environ["SHOCKDYNO_HISTORY"] = str(Path(folder) / "history.sqlite")
    config.add_cleanup(lambda: shutil.rmtree(folder, ignore_errors=True))
