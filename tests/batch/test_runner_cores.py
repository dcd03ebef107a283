"""The local cluster's default size is the cores this process may run on (its affinity)."""

from __future__ import annotations

from typing import Any

from shockdyno.batch import runner


class _Client:
    dashboard_link = None

    def close(self) -> None:
        pass


def test_the_default_cluster_has_one_worker_per_usable_core(monkeypatch) -> None:
    sizes: list[Any] = []

    def client(scheduler: str | None, workers: int) -> tuple[_Client, None]:
        sizes.append((scheduler, workers))
        return _Client(), None

    monkeypatch.setattr(runner, "_client", client)
    # A process pinned to 3 of the machine's cores (taskset, a container's cpuset).
    monkeypatch.setattr(runner, "usable_cores", lambda: 3)
    with runner.dask_client(None, None):
        pass
    with runner.dask_client(None, 5):
        pass
    assert sizes == [(None, 3), (None, 5)]
