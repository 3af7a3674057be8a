"""Property: an episode's cost does not depend on the units of the plant.

``K G(s) e^{-Ls} -> g K G(c s) e^{-L c s}``: the experiments are sized for a unit rise of the output
and run on a grid proportional to the identified ``T_ar``, and the cost is made dimensionless with
the true gain and ``T_ar``, so the same seed gives the same observation and the same reward in any
unit of gain (either sign) and time, with measurement noise.  Agreement is to rounding.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from envs.systems.plants import Plant
from envs.tuning_env import FPPIEnv, MSPEnv, PIDEnv

ENVS = {"pid": PIDEnv(), "fppi": FPPIEnv(), "msp": MSPEnv()}


def _scaled(plant: Plant, gain: float, time: float) -> Plant:
    num = gain * np.asarray(plant.num) * time ** np.arange(len(plant.num))[::-1]
    den = np.asarray(plant.den) * time ** np.arange(len(plant.den))[::-1]
    return Plant(tuple(num), tuple(den), plant.dead_time * time)


@settings(max_examples=12, deadline=None, derandomize=True)
@given(
    structure=st.sampled_from(sorted(ENVS)),
    seed=st.integers(0, 10_000),
    gain=st.floats(1e-3, 1e3).flatmap(lambda g: st.sampled_from([g, -g])),
    time=st.floats(1e-3, 1e3),
    action=st.floats(-1.0, 1.0),
)
def test_episode_cost_is_invariant_to_gain_and_time_units(structure, seed, gain, time, action):
    env = ENVS[structure]
    env.reset(seed=seed)
    plant = env.plant
    outcomes = []
    for candidate in (plant, _scaled(plant, gain, time)):
        obs, _ = env.reset(seed=seed, options={"plant": candidate})
        _, reward, *_ = env.step(np.array([action], dtype=np.float32))
        outcomes.append((obs, reward))
    np.testing.assert_allclose(outcomes[1][0], outcomes[0][0], rtol=1e-6, atol=1e-6)
    assert outcomes[1][1] == pytest.approx(outcomes[0][1], rel=1e-6, abs=1e-9)
