"""The Python API runs its numerics with one BLAS thread, scoped to its own calls (:mod:`envs.threads`).

Each case runs in a fresh interpreter, because OpenBLAS reads ``OPENBLAS_NUM_THREADS`` once, when
numpy loads: a user's process with two BLAS threads is limited to one inside our calls, gets its two
back afterwards, and gets the same episode bit for bit as a process started with one thread.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

SCRIPT = r"""
import json
import gymnasium as gym
import numpy as np
from threadpoolctl import threadpool_info

import envs
from envs.threads import single_threaded


def blas_threads():
    return sorted({info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas"})


@single_threaded
def inner():
    return blas_threads()


@single_threaded
def outer():
    return inner(), blas_threads()


before = blas_threads()
nested = outer()
env = gym.make("DeadTime/PID-v0")
observation, _ = env.reset(seed=3)
_, reward, *_ = env.step(np.zeros(1, dtype=np.float32))
print(json.dumps({"before": before, "nested": nested, "after": blas_threads(),
                  "episode": [observation.tolist(), reward]}))
"""


def _run(threads: str) -> dict:
    environment = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    environment["OPENBLAS_NUM_THREADS"] = threads
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, env=environment, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def runs() -> dict[str, dict]:
    return {threads: _run(threads) for threads in ("1", "2")}


def test_calls_run_single_threaded_and_restore_the_users_threads(runs: dict[str, dict]) -> None:
    two = runs["2"]
    assert two["before"] == [2]
    assert two["nested"] == [[1], [1]]  # the outer call's limit holds through the inner call
    assert two["after"] == [2]


def test_a_single_threaded_process_is_left_alone(runs: dict[str, dict]) -> None:
    one = runs["1"]
    assert one["before"] == one["after"] == [1]
    assert one["nested"] == [[1], [1]]


def test_same_episode_whatever_the_users_threads(runs: dict[str, dict]) -> None:
    assert runs["1"]["episode"] == runs["2"]["episode"]
