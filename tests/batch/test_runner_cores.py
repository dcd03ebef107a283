"""How many local workers a batch starts: the cores this process may run on (its affinity),
never more than there are recordings."""

from __future__ import annotations

from typing import Any

import pytest

from shockdyno.batch import runner


@pytest.fixture
def sizes(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The number of workers each map_tasks call would start, without starting them, on a
    process pinned to 3 of the machine's cores (taskset, a container's cpuset)."""
    started: list[int] = []

    class Workers:
        def __init__(self, fn: Any, n: int, warm: Any) -> None:
            started.append(n)

        def __enter__(self) -> Workers:
            return self

        def __exit__(self, *exc: object) -> None:
            pass

        def results(self, items: list[int]) -> list[tuple[int, int]]:
            return [(x, x) for x in items]

    monkeypatch.setattr(runner, "LocalWorkers", Workers)
    monkeypatch.setattr(runner, "usable_cores", lambda: 3)
    return started


def test_the_default_is_one_local_worker_per_usable_core(sizes: list[int]) -> None:
    seen: list[str] = []
    items = [1, 2, 3, 4]
    assert list(runner.map_tasks(abs, items, on_cluster=seen.append)) == [(x, x) for x in items]
    assert list(runner.map_tasks(abs, items, workers=4)) == [(x, x) for x in items]
    assert sizes == [3, 4]
    assert seen == ["3 local worker processes"]


def test_no_more_local_workers_than_recordings(sizes: list[int]) -> None:
    seen: list[str] = []
    assert list(runner.map_tasks(abs, [1], workers=5, on_cluster=seen.append)) == [(1, 1)]
    assert list(runner.map_tasks(abs, [1, 2])) == [(1, 1), (2, 2)]
    assert sizes == [1, 2]
    assert seen == ["1 local worker process"]
