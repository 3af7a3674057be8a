"""A tiny protocol for the tests of protocol runs, reports and studies: a learned rule fitted on a few
training plants, two seeds, a few validation and test plants, PID regimes of a given noise.
``write_tiny_protocol(folder, ...)``; imported by name (tests/conftest.py puts this folder on ``sys.path``).
"""

from __future__ import annotations

from pathlib import Path

from agents.protocol.config import load_protocol
from agents.protocol.streams import register_test_seed

RULE = """default:
  algorithm: learned-rule
  env_id: DeadTime/PID-v3
  env_kwargs: {{experiments: fixed}}
  seed: 0
  training_plants: {training_plants}
  validation_plants: 10
  margins: [0.0, 0.2]
  models: [quantile-boosting]
"""

PROTOCOL = """name: tiny
seeds: {{first: 0, count: 2}}
alpha: 0.05
streams:
  validation: {{entropy: {entropy}, plants: {validation_plants}, episode_seed: 50000000}}
  test: {{entropy: 12, plants: {test_plants}, episode_seed: 60000000}}
selection:
  violation_target: 0.5
  confidence: 0.95
  rules: [simc-pi, gorez-klan-mu-2]
  plans: [plan-1-1, plan-3-0.1]
  fixed_procedure: plan-1-1
comparisons: {comparisons}
regimes:
{regimes}"""

REGIME = """  - name: {name}
    env: DeadTime/PID-v3
    env_kwargs: {{noise_std: {noise}}}
    fixed:
      - {{label: tiny-fixed, config: {rule}}}
{wide}    plan:
      - {{label: tiny-plan, config: {rule}, overrides: ["env_kwargs.plan=[3, 0.1]"]}}
"""

WIDE = """      - {{label: tiny-fixed-wide, config: {rule}, overrides: ["margins=[0.5]"]}}
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
    pretrained: [learned-pid@0.05]
  - name: pid-noisy
    env: DeadTime/PID-v3
    env_kwargs: {{noise_std: 0.05}}
    rules: [amigo-pid]
    fixed: [{{label: tiny-fixed, config: {rule}}}]
"""


COMPARISONS = "[[fixed, best-rule], [plan, best-rule], [plan, fixed-procedure], [plan, best-plan]]"


def write_rule(folder: Path, training_plants: int = 30) -> Path:
    """The learned rule's config (``rule.yaml`` in ``folder``): its path."""
    path = folder / "rule.yaml"
    path.write_text(RULE.format(training_plants=training_plants))
    return path


def write_tiny_protocol(folder: Path, *, regimes: dict[str, float] | None = None, plants: tuple[int, int, int] = (30, 5, 6),
                        entropy: int = 11, wide: bool = False, comparisons: str = COMPARISONS, regimes_text: str | None = None,
                        edits: tuple[tuple[str, str], ...] = (), file_name: str = "tiny", register: bool = False) -> Path:
    """The tiny protocol written to ``folder/protocols/FILE_NAME.yaml`` (its rule to ``folder/rule.yaml``): its path.

    ``regimes`` maps a regime's name to its noise (one regime ``pid-tiny`` of noise 0.01 if not given), each
    with a fixed-mode learner ``tiny-fixed`` (and ``tiny-fixed-wide`` if ``wide``) and a plan-mode one
    ``tiny-plan``, or the regimes as written in ``regimes_text`` (a YAML list, formatted with ``rule``: the rule's
    path); ``plants`` are the training plants of a fit and the validation and test plants; ``entropy``
    the validation stream's; ``edits`` pairs of text replaced once each (each must occur); ``register``
    writes the test stream's entry into ``test_seeds.json`` beside the file."""
    rule = write_rule(folder, plants[0])
    if regimes_text is None:
        regimes_text = "".join(REGIME.format(name=name, noise=noise, rule=rule, wide=WIDE.format(rule=rule) if wide else "")
                               for name, noise in (regimes or {"pid-tiny": 0.01}).items())
    text = PROTOCOL.format(entropy=entropy, validation_plants=plants[1], test_plants=plants[2], comparisons=comparisons,
                           regimes=regimes_text.replace("{rule}", str(rule)))
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    return _write(folder / "protocols" / f"{file_name}.yaml", text, register)


def write_tiny_frontier_protocol(folder: Path) -> Path:
    """The tiny frontier protocol (two PID regimes, two seeds, a few plants, three knobs, its learned rule fitted on
    20 training plants) written to ``folder/protocols/tiny-frontier.yaml`` and registered: its path."""
    return _write(folder / "protocols" / "tiny-frontier.yaml", FRONTIER.format(rule=write_rule(folder, 20)), register=True)


def _write(path: Path, text: str, register: bool) -> Path:
    """``text`` written to ``path`` (its folder created); ``register`` writes the test stream's entry into
    ``test_seeds.json`` beside it.  Its path."""
    path.parent.mkdir(exist_ok=True)
    path.write_text(text)
    if register:
        protocol = load_protocol(path)
        register_test_seed(protocol.test.entropy, protocol.path, protocol.sha256, path.with_name("test_seeds.json"))
    return path
