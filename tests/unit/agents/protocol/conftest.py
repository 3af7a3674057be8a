"""A tiny protocol for the tests of its run: two regimes, two seeds, a few plants, 20 training plants per fit."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from agents.protocol.config import load_protocol
from agents.protocol.streams import register_test_seed

RULE = """default:
  algorithm: learned-rule
  env_id: DeadTime/PID-v3
  env_kwargs: {experiments: fixed}
  seed: 0
  training_plants: 20
  validation_plants: 10
  margins: [0.0, 0.2]
  models: [quantile-boosting]
"""

PROTOCOL = """name: tiny
seeds: {{first: 0, count: 2}}
alpha: 0.05
streams:
  validation: {{entropy: 11, plants: 4, episode_seed: 50000000}}
  test: {{entropy: 12, plants: 5, episode_seed: 60000000}}
selection:
  violation_target: 0.5
  confidence: 0.95
  rules: [simc-pi, gorez-klan-mu-2]
  plans: [plan-1-1, plan-3-0.1]
  fixed_procedure: plan-1-1
comparisons: [[fixed, best-rule], [plan, best-rule], [plan, fixed-procedure]]
regimes:
  - name: pid-quiet
    env: DeadTime/PID-v3
    env_kwargs: {{noise_std: 0.01}}
    fixed: [{{label: tiny-fixed, config: {rule}}}]
    plan: [{{label: tiny-plan, config: {rule}, overrides: ["env_kwargs.plan=[3, 0.1]"]}}]
  - name: pid-noisy
    env: DeadTime/PID-v3
    env_kwargs: {{noise_std: 0.05}}
    fixed: [{{label: tiny-fixed, config: {rule}}}]
    plan: [{{label: tiny-plan, config: {rule}, overrides: ["env_kwargs.plan=[3, 0.1]"]}}]
"""


FRONTIER = """name: tiny-frontier
seeds: {{first: 0, count: 2}}
alpha: 0.05
streams:
  validation: {{entropy: 21, plants: 4, episode_seed: 70000000}}
  test: {{entropy: 22, plants: 5, episode_seed: 80000000}}
frontier:
  knobs: [-0.5, 0, 0.5]
  risk_levels: [0.005, 0.01, 0.02, 0.05, 0.5]
  rules: [simc-pi, gorez-klan-mu-2]
  min_seeds: 2
regimes:
  - name: pid-quiet
    env: DeadTime/PID-v3
    env_kwargs: {{noise_std: 0.01}}
    fixed: [{{label: tiny-fixed, config: {rule}}}]
  - name: pid-noisy
    env: DeadTime/PID-v3
    env_kwargs: {{noise_std: 0.05}}
    rules: [amigo-pid]
    fixed: [{{label: tiny-fixed, config: {rule}}}]
"""


def write_tiny_frontier_protocol(folder: Path) -> Path:
    """The tiny frontier protocol (two regimes, two seeds, a few plants, three knobs), written into ``folder``
    and registered.  Its path."""
    (folder / "rule.yaml").write_text(RULE)
    (folder / "protocols").mkdir()
    path = folder / "protocols" / "tiny-frontier.yaml"
    path.write_text(FRONTIER.format(rule=folder / "rule.yaml"))
    protocol = load_protocol(path)
    register_test_seed(protocol.test.entropy, protocol.path, protocol.sha256, path.with_name("test_seeds.json"))
    return path


def write_tiny_protocol(folder: Path) -> Path:
    """Two regimes, two seeds, a few plants, written into ``folder`` and registered.  Its path."""
    (folder / "rule.yaml").write_text(RULE)
    (folder / "protocols").mkdir()
    path = folder / "protocols" / "tiny.yaml"
    path.write_text(PROTOCOL.format(rule=folder / "rule.yaml"))
    protocol = load_protocol(path)
    register_test_seed(protocol.test.entropy, protocol.path, protocol.sha256, path.with_name("test_seeds.json"))
    return path


@pytest.fixture(autouse=True, scope="session")
def _uncommitted_code_allowed() -> Iterator[None]:
    """The protocol runs of these tests run from the tree under test, committed or not (their protocol.json
    marked so where it is not); tests/unit/agents/protocol/test_code.py checks the refusal itself."""
    import os

    before = os.environ.get("DEADTIME_UNCOMMITTED_CODE")
    os.environ["DEADTIME_UNCOMMITTED_CODE"] = "1"
    yield
    if before is None:
        os.environ.pop("DEADTIME_UNCOMMITTED_CODE")
    else:
        os.environ["DEADTIME_UNCOMMITTED_CODE"] = before


@pytest.fixture
def tiny_protocol() -> Callable[[Path], Path]:
    """:func:`write_tiny_protocol`."""
    return write_tiny_protocol


@pytest.fixture(scope="module")
def tiny_serial_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The tiny protocol run in this process, one task after another: its path and its run folder."""
    from agents.protocol.run import run_protocol

    folder = tmp_path_factory.mktemp("serial")
    path = write_tiny_protocol(folder)
    assert run_protocol(load_protocol(path), folder / "out") == ["pid-quiet", "pid-noisy"]
    return path, folder / "out"
