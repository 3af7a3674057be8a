"""The wrapper that adds the oracle's figures to an episode's final ``info``
(:mod:`agents.evaluation.oracle_info`; the environments themselves import no baseline)."""

from __future__ import annotations

import numpy as np
import pytest

from agents.evaluation.oracle_info import OracleInfo
from envs.tuning_env import PIDEnv


@pytest.mark.slow
def test_oracle_cost_in_info_is_no_worse_than_the_policy():
    env = OracleInfo(PIDEnv())
    env.reset(seed=1)
    info = env.step(np.array([0.0], dtype=np.float32))[4]
    assert info["oracle_cost"] <= info["cost"] + 1e-9
