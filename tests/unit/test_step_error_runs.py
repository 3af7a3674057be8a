"""The compiled pieces of the IAE (envs.step_error_runs) against numpy, bit for bit.

The whole path (step runs continued over the horizons, areas, sums, settling test) is checked
against the general simulation in ``tests/unit/test_resumable_runs.py``; here the summation on its
own, over every length class of numpy's pairwise algorithm (``< 8``, ``<= 128``, split in halves)
and for ranges that start anywhere.
"""

from __future__ import annotations

import numpy as np
import pytest

from envs.step_error_runs import _pairwise_sum


@pytest.mark.parametrize("seed", range(3))
def test_pairwise_sum_equals_numpy_sum(seed):
    rng = np.random.default_rng(seed)
    lengths = list(range(0, 300)) + rng.integers(300, 70_000, 60).tolist()
    for n in lengths:
        values = rng.random(n) * 10.0 ** rng.uniform(-6, 6, n)
        assert _pairwise_sum(values, 0, n) == np.sum(values)
        start = int(rng.integers(0, max(n // 2, 1)))
        assert _pairwise_sum(values, start, n) == np.sum(values[start:])
