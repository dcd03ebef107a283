"""The local workers' default number is the cores this process may run on (its affinity)."""

from __future__ import annotations

from typing import Any

import pytest

from shockdyno.batch import runner


def test_the_default_is_one_local_worker_per_usable_core(monkeypatch: pytest.MonkeyPatch) -> None:
    sizes: list[int] = []

    class Workers:  # what the workers would be started with, without starting them
        def __init__(self, fn: Any, n: int, warm: Any) -> None:
            sizes.append(n)

        def __enter__(self) -> Workers:
            return self

        def __exit__(self, *exc: object) -> None:
            pass

        def results(self, items: list[int]) -> list[tuple[int, int]]:
            return [(x, x) for x in items]

    monkeypatch.setattr(runner, "LocalWorkers", Workers)
    # A process pinned to 3 of the machine's cores (taskset, a container's cpuset).
    monkeypatch.setattr(runner, "usable_cores", lambda: 3)
    seen: list[str] = []
    assert list(runner.map_tasks(abs, [1, 2], on_cluster=seen.append)) == [(1, 1), (2, 2)]
    assert list(runner.map_tasks(abs, [1], workers=5)) == [(1, 1)]
    assert sizes == [3, 5]
    assert seen == ["3 local worker processes"]
