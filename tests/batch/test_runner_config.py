"""The local cluster's workers get the Dask settings a fit runs best under: glibc's own
malloc trim threshold, and no statistical profiler sampling the fit's stack every 10 ms."""

from __future__ import annotations

from typing import Any

import distributed
import pytest

from shockdyno.batch import runner


def test_the_local_cluster_is_made_without_the_profiler_and_with_glibcs_trim(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    seen: dict[str, Any] = {}

    class Cluster:  # what the workers would be started with, without starting them
        def __init__(self, **kwargs: Any) -> None:
            import dask

            seen["profile"] = dask.config.get("distributed.worker.profile.enabled")
            key = "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"
            seen["trim"] = dask.config.get(key)
            seen["threads"] = kwargs["threads_per_worker"]

    monkeypatch.setattr(distributed, "LocalCluster", Cluster)
    monkeypatch.setattr(distributed, "Client", lambda cluster: cluster)
    _, cluster = runner._client(None, 2)
    assert isinstance(cluster, Cluster)
    assert seen == {"profile": False, "trim": 128 * 1024 * 1024, "threads": 1}
    import dask

    assert dask.config.get("distributed.worker.profile.enabled") is True  # only there
