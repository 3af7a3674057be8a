"""Shared by the tests of agents/: a Ray cluster started by ``ray start`` (tests/ray_cluster.py)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from ray_cluster import ray_head_node


@pytest.fixture
def ray_start_cluster() -> Iterator[tuple[str, dict[str, str]]]:
    """:func:`ray_cluster.ray_head_node`: its address and a driver's environment."""
    with ray_head_node() as cluster:
        yield cluster
