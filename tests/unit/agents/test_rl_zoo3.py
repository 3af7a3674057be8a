"""rl-zoo3, the usual way stable-baselines3 users train, on a DeadTime id in an environment of its own.

rl-zoo3 2.9.0 requires ``gymnasium>=0.29.1,<1.3`` (its package metadata) and the project's pinned
install has gymnasium 1.4.0 (constraints.txt), so the two cannot share one virtual environment.  The
environments run under gymnasium 1.2, so this builds a virtual environment beside the test with what
``envs`` needs (pinned by constraints.txt) but gymnasium 1.2.x, the project on ``PYTHONPATH``, and
rl-zoo3 2.9.0; trains a few steps of SAC on ``DeadTime/PID-v3`` with
``python -m rl_zoo3.train`` and configs/rl_zoo3/sac.yaml, and loads the saved model there; then, in the
project's own environment, converts it (``deadtime convert-model --trust``, with rl-zoo3's statistics
copied beside the model) and scores it with ``deadtime evaluate``.
docs/training_and_evaluation.md ("Training with rl-zoo3") states the supported range.

Slow (minutes: the installs and the first episodes' compilation); skipped, with the reason, when the
package registry cannot be reached.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
RL_ZOO3 = "rl_zoo3==2.9.0"
GYMNASIUM = "gymnasium>=1.2,<1.3"
TORCH = "torch==2.13.0"
"""The project's pin (pyproject.toml); pip finds its CPU build among the machine's local wheels."""
ENVS_NEEDS = ("numpy", "scipy", "numba", "threadpoolctl")
"""The packages ``envs`` imports at the top of its modules (matplotlib and tclab only inside functions the
training does not call); stable-baselines3 comes with rl-zoo3."""
INSTALL_TIMEOUT_S = 1800
"""Hang guards only (the whole test took 243 s on two cores at load 12)."""
TRAIN_TIMEOUT_S = 1800

LOAD = """
import sys
import gymnasium as gym
from stable_baselines3 import SAC
import envs  # registers the ids
model = SAC.load(sys.argv[1], device="cpu")
env = gym.make("DeadTime/PID-v3")
observation, _ = env.reset(seed=0)
action, _ = model.predict(observation, deterministic=True)
assert env.action_space.contains(action), action
print(gym.__version__, model.num_timesteps)
"""


def _run(command: list[str], timeout: float, **kwargs) -> subprocess.CompletedProcess[str]:
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, check=False, **kwargs)


def _name(requirement: str) -> str:
    return re.split(r"[<>=!~;\[ ]", requirement, maxsplit=1)[0].strip().lower().replace("_", "-")


def _requirements(constraints: Path) -> list[str]:
    """What ``envs`` imports (:data:`ENVS_NEEDS`), gymnasium 1.2.x and rl-zoo3; ``constraints`` is written with
    constraints.txt's pins of the first and of stable-baselines3 and sb3-contrib (not of everything constraints.txt pins: rl-zoo3's own
    dependencies need other versions of some, e.g. python-dateutil < 3 for pytablewriter)."""
    pinned = {*ENVS_NEEDS, "stable-baselines3", "sb3-contrib"}  # the latter two come with rl-zoo3
    pins = [line for line in (REPO / "constraints.txt").read_text().splitlines() if line and _name(line) in pinned]
    constraints.write_text("\n".join(pins) + "\n")
    return [*ENVS_NEEDS, GYMNASIUM, RL_ZOO3]


@pytest.mark.slow
def test_rl_zoo3_trains_sac_on_a_deadtime_id_under_gymnasium_1_2(tmp_path: Path) -> None:
    probe = _run([sys.executable, "-m", "pip", "download", "--no-deps", "-q", "-d", str(tmp_path / "probe"), RL_ZOO3], 600)
    if probe.returncode != 0:
        pytest.skip(f"the package registry is unreachable ({RL_ZOO3} could not be downloaded): "
                    f"{(probe.stderr.strip().splitlines() or ['no message'])[-1]}")
    venv = tmp_path / "venv"
    assert _run([sys.executable, "-m", "venv", str(venv)], 600).returncode == 0
    python = str(venv / "bin" / "python")
    constraints = tmp_path / "constraints.txt"
    requirements = _requirements(constraints)
    for packages in ([TORCH], requirements):  # torch first: its CPU build, not a CUDA one, from the local wheels
        installed = _run([python, "-m", "pip", "install", "-q", "-c", str(constraints), *packages], INSTALL_TIMEOUT_S)
        assert installed.returncode == 0, installed.stderr[-3000:]

    environment = {**os.environ, "PYTHONPATH": str(REPO)}
    logs = tmp_path / "logs"
    train = _run([python, "-m", "rl_zoo3.train", "--algo", "sac", "--env", "DeadTime/PID-v3", "--gym-packages", "envs",
                  "--conf-file", str(REPO / "configs" / "rl_zoo3" / "sac.yaml"), "-n", "64", "--seed", "0",
                  "--device", "cpu", "--log-folder", str(logs), "--eval-freq", "-1",
                  "--hyperparams", "learning_starts:16", "batch_size:16"],
                 TRAIN_TIMEOUT_S, cwd=tmp_path, env=environment)
    assert train.returncode == 0, (train.stdout[-2000:], train.stderr[-3000:])
    models = sorted(logs.glob("sac/*/*.zip"))
    assert models, sorted(str(p.relative_to(logs)) for p in logs.rglob("*"))

    loaded = _run([python, "-c", LOAD, str(models[0])], 600, cwd=tmp_path, env=environment)
    assert loaded.returncode == 0, loaded.stderr[-3000:]
    version, steps = loaded.stdout.split()
    assert version.startswith("1.2.") and int(steps) == 64

    model = models[0]
    statistics = model.parent / model.stem / "vecnormalize.pkl"  # where rl-zoo3 saves them
    (model.parent / f"{model.stem}.vecnormalize.pkl").write_bytes(statistics.read_bytes())
    ours = {**os.environ, "PYTHONPATH": str(REPO)}
    converted = _run([sys.executable, "-m", "agents.cli", "convert-model", str(model), "--trust", "--env", "DeadTime/PID-v3"],
                     600, cwd=tmp_path, env=ours)
    assert converted.returncode == 0, converted.stderr[-3000:]
    evaluated = _run([sys.executable, "-m", "agents.cli", "evaluate", "--env", "DeadTime/PID-v3", "--policies",
                      f"zoo={model}", "--n", "2", "--seed", "0", "--out", str(tmp_path / "eval")],
                     1200, cwd=tmp_path, env=ours)
    assert evaluated.returncode == 0, evaluated.stderr[-3000:]
    assert "zoo" in (tmp_path / "eval" / "results.md").read_text()
