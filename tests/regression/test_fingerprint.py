"""A fingerprint of the numbers a refactor must not change.

Observations, rewards and final ``info`` of seeded episodes of every environment id in both modes
(random actions from a seeded generator in agent mode), and the outputs of ``deadtime analyze
--json``, ``deadtime tune --json`` (every rule on a stable and an integrating plant, errors
included) and ``deadtime reproduce all --json``, recorded in ``fingerprint.json`` beside this file.

The check is bit for bit (floats through ``repr``, ``nan`` and ``inf`` included), which is only
defined on the same machine and libraries (docs/environments/overview.md, "Determinism, precisely"): the file records the
machine it was written on (CPU architecture, BLAS kernel, numpy/scipy/numba versions), and on a
machine that differs the test is skipped with the reason.  Only a deliberate, documented change of
behaviour may rewrite the file, in its own commit::

    DEADTIME_WRITE_FINGERPRINT=1 python -m pytest tests/regression/test_fingerprint.py

(also the way to record one on another machine before a refactor there).
"""

from __future__ import annotations

import io
import json
import os
import platform
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from agents.cli import main
from baselines.rules.registry import RULES

FILE = Path(__file__).with_name("fingerprint.json")
IDS = ("DeadTime/PID-v0", "DeadTime/FPPI-v0", "DeadTime/MSP-v0")
VERSIONS_FILE = Path(__file__).with_name("fingerprint_versions.json")
"""The episodes of the later versions (same seeds and actions as the v0 episodes of :data:`FILE`); a
version's entries are recorded when it is registered and never change after."""
VERSION_IDS = tuple(f"DeadTime/{structure}-{version}" for version in ("v1", "v2", "v3") for structure in ("PID", "FPPI", "MSP"))
EPISODES = {"fixed": 12, "agent": 6}
PLANTS = {
    "stable": {"num": [1.0], "den": [2.0, 3.0, 1.0], "delay": 1.0},
    "integrating": {"num": [1.0], "den": [2.0, 1.0, 0.0], "delay": 5.0},
}
ANALYZE = [
    (PLANTS["stable"], {"type": "pid", "kp": 1.2, "ti": 2.5, "td": 0.4, "n": 10}),
    ({"num": [1], "den": [10, 1], "delay": 5}, {"type": "pid", "kp": 1.2, "ti": 9, "td": 1.5, "n": 10}),
    ({"num": [1], "den": [10, 1], "delay": 5},
     {"type": "fppi", "model": {"gain": 1, "time_constant": 9, "dead_time": 6}, "tr": 3, "tf": 3}),
    (PLANTS["integrating"], {"type": "msp", "model": {"gain": 1, "dead_time": 5.5}, "tr": 5, "extension": False}),
    (PLANTS["stable"], {"type": "pid", "kp": 30, "ti": 1, "td": 0, "n": 10}),  # unstable loop
]


def _machine() -> dict[str, Any]:
    import numba
    import scipy
    from threadpoolctl import threadpool_info

    kernels = sorted({f"{i['internal_api']}:{i.get('architecture')}" for i in threadpool_info() if i["user_api"] == "blas"})
    return {"machine": platform.machine(), "blas": kernels, "numpy": np.__version__, "scipy": scipy.__version__,
            "numba": numba.__version__, "coretype": os.environ.get("OPENBLAS_CORETYPE")}


def _cli(*args: str) -> dict[str, Any]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        status = main(list(args))
    return {"status": status, "stdout": out.getvalue(), "stderr": err.getvalue()}


def _episode(env_id: str, mode: str, seed: int) -> dict[str, Any]:
    env = gym.make(env_id, experiments=mode)
    actions = np.random.default_rng(seed)
    observation, info = env.reset(seed=seed)
    record: dict[str, Any] = {"observations": [observation.tolist()], "rewards": [], "reset_info": info}
    done = False
    while not done:
        action = actions.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
        observation, reward, terminated, truncated, info = env.step(action)
        record["observations"].append(observation.tolist())
        record["rewards"].append(reward)
        done = terminated or truncated
    record["final_info"] = info
    return record


def _episodes(ids: tuple[str, ...]) -> dict[str, Any]:
    return {f"{env_id}/{mode}/{seed}": _episode(env_id, mode, seed)
            for env_id in ids for mode, count in EPISODES.items() for seed in range(count)}


def fingerprint() -> dict[str, Any]:
    """Everything the fingerprint holds, as JSON-ready values."""
    episodes = _episodes(IDS)
    analyze = [_cli("analyze", "--plant", json.dumps(p), "--controller", json.dumps(c), "--json") for p, c in ANALYZE]
    tune = {f"{rule}/{kind}": _cli("tune", "--rule", rule, "--plant", json.dumps(plant), "--json")
            for rule in RULES for kind, plant in PLANTS.items()}
    return {"episodes": episodes, "analyze": analyze, "tune": tune, "reproduce": _cli("reproduce", "all", "--json")}


def _canonical(value: Any) -> Any:
    """The value as it reads back from JSON (tuples as lists, float32 as float), for exact comparison."""
    return json.loads(json.dumps(value, default=float))


def _first_difference(expected: Any, actual: Any, path: str = "") -> str | None:
    if isinstance(expected, dict) and isinstance(actual, dict):
        if expected.keys() != actual.keys():
            return f"{path}: keys {sorted(set(expected) ^ set(actual))} differ"
        for key in expected:
            found = _first_difference(expected[key], actual[key], f"{path}/{key}")
            if found:
                return found
        return None
    if isinstance(expected, list) and isinstance(actual, list):
        if len(expected) != len(actual):
            return f"{path}: length {len(expected)} != {len(actual)}"
        for index, (a, b) in enumerate(zip(expected, actual)):
            found = _first_difference(a, b, f"{path}[{index}]")
            if found:
                return found
        return None
    same = expected == actual or (isinstance(expected, float) and isinstance(actual, float) and expected != expected and actual != actual)
    return None if same else f"{path}: {expected!r} != {actual!r}"


def _check(file: Path, compute) -> None:
    """``compute()`` equal bit for bit to what ``file`` recorded (or recorded, see the module docstring)."""
    actual = _canonical(compute())
    if os.environ.get("DEADTIME_WRITE_FINGERPRINT"):
        file.write_text(json.dumps({"machine": _machine(), "fingerprint": actual}, indent=None) + "\n")
        pytest.skip(f"wrote {file}")
    recorded = json.loads(file.read_text())
    if recorded["machine"] != _canonical(_machine()):
        pytest.skip(f"fingerprint recorded on {recorded['machine']}, this is {_machine()}: bit identity is defined "
                    "only on the same machine and libraries")
    difference = _first_difference(recorded["fingerprint"], actual)
    assert difference is None, difference


@pytest.mark.slow
def test_numbers_are_bit_identical_to_the_fingerprint(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # `reproduce all` writes figures/ into the working directory (recorded as relative paths)
    _check(FILE, fingerprint)


def test_later_versions_are_bit_identical_to_their_fingerprint() -> None:
    """The v1-v3 episodes (a few seconds, so in the fast suite)."""
    _check(VERSIONS_FILE, lambda: _episodes(VERSION_IDS))
