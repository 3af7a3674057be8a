"""Policies on a process: the commissioning controller, the rules, the process oracle and agents.

Every policy reads the same experiments (:func:`envs.process.procedure.identify_process`) and gives
a controller, which :func:`envs.process.scoring.process_score` tests on the process itself and
judges on the identified model:

* ``commissioning``: the loop's existing controller (given or designed from the first step);
* a rule: ``rule(RuleInputs.from_identification(identification))``, as ``deadtime evaluate`` and
  ``deadtime tune`` design it (:mod:`baselines.rules.registry`);
* ``oracle``: :func:`baselines.process_oracle.process_oracle`, the PID's ``mu`` searched with process
  runs (``oracle-fppi``: the FPPI's ``T_r``);
* an agent trained in a fixed-mode environment (``DeadTime/PID-v0`` or ``FPPI-v0``): its observation is built from
  the process's experiments exactly as the environment builds it at ``reset``
  (:func:`agent_observation`: :func:`envs.episode.evidence_from_identification`, then
  :func:`envs.episode.features` over the environment's budget, clipped to its observation bounds,
  float32), its action is mapped to the parameter by the environment's own
  ``parameter_from_action``, and the controller is the environment's design
  (:func:`envs.structures.design` on the identified model).

A policy that cannot give a controller here (a rule undefined for these inputs, a controller with
no discrete law, an agent of the agent mode) is a failure with its reason, not an error of the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from envs.process.performance import RunProtocol
from envs.process.procedure import ProcessIdentification
from envs.process.protocol import Process
from envs.process.scoring import ProcessScore, process_score

__all__ = ["ProcessPolicyResult", "agent_observation", "evaluate_policies", "DEFAULT_AGENT_ENV"]

DEFAULT_AGENT_ENV = "DeadTime/PID-v0"
"""The environment of an agent saved without its config (it is then taken as a PID-v0 agent)."""


@dataclass(frozen=True)
class ProcessPolicyResult:
    """One policy on the process: its controller and score, or why it has none.

    ``role`` is ``"commissioning"``, ``"rule"``, ``"oracle"`` or ``"agent"``; ``parameter`` the
    relative design parameter where the policy has one (``mu``; as the agent's and the oracle's).
    """

    name: str
    role: str
    controller: Any = None
    parameter: float | None = None
    score: ProcessScore | None = None
    error: str | None = None


def agent_observation(found: ProcessIdentification, budget: int) -> np.ndarray:
    """The fixed-mode observation of the process's experiments, as the environment builds it at
    ``reset`` (see the module docstring); the noise ratio is ``sigma/|setpoint_step|``."""
    from envs.episode import evidence_from_identification, features
    from envs.episode_options import EpisodeOptions
    from envs.tuning_env import OBSERVATION_BOUND

    evidence = evidence_from_identification(found.identification, EpisodeOptions(noise_std=found.noise_ratio))
    values = features(evidence, budget)
    return np.clip(values, -OBSERVATION_BOUND, OBSERVATION_BOUND).astype(np.float32)


def _rule(process, found, protocol, name: str) -> ProcessPolicyResult:
    from baselines.rules.registry import RuleInputs, get_rule

    rule = get_rule(name)
    try:
        inputs = RuleInputs.from_identification(found.identification)
        controller = rule(inputs)
        parameter = rule.relative_parameter(inputs)
        return ProcessPolicyResult(name, "rule", controller, parameter, process_score(process, controller, found, protocol))
    except ValueError as error:
        return ProcessPolicyResult(name, "rule", error=str(error))


def _oracle(process, found, protocol, structure: str, name: str) -> ProcessPolicyResult:
    from baselines.process_oracle import process_oracle

    try:
        result = process_oracle(process, found, protocol, structure)
    except ValueError as error:
        return ProcessPolicyResult(name, "oracle", error=str(error))
    return ProcessPolicyResult(name, "oracle", result.controller, result.relative_parameter, result.score)


def _agent(process, found, protocol, spec: Any) -> ProcessPolicyResult:
    from agents.environments import make_env
    from agents.evaluation.policies import load_agent
    name, policy = load_agent(spec)  # a file that cannot be loaded is bad input (one line, exit 2)
    env_id = getattr(policy, "env_id", None) or DEFAULT_AGENT_ENV
    env = make_env(env_id, getattr(policy, "env_kwargs", {}) or {}).unwrapped
    if env.mode != "fixed":
        return ProcessPolicyResult(name, "agent", error=f"the agent plays {env_id} in agent mode (it chooses its experiments); "
                                   "on a process the fixed procedure runs, so only fixed-mode agents apply")
    if env.kind.integrating:
        return ProcessPolicyResult(name, "agent", error=f"the agent designs the modified Smith predictor of {env_id}, for "
                                   "integrating plants; the procedure here identifies self-regulating processes")
    observation = agent_observation(found, env.budget)
    action, _ = policy.predict(observation, deterministic=True)
    relative = env.parameter_from_action(float(np.asarray(action, dtype=np.float64).reshape(-1)[-1]))
    controller = env.kind.relative_design(env.kind.model_of(found.identification), relative)
    try:
        return ProcessPolicyResult(name, "agent", controller, relative, process_score(process, controller, found, protocol))
    except ValueError as error:
        return ProcessPolicyResult(name, "agent", controller, relative, error=str(error))


def evaluate_policies(
    process: Process, found: ProcessIdentification, protocol: RunProtocol, specs: list, fppi_oracle: bool = False
) -> list[ProcessPolicyResult]:
    """The commissioning controller, then each policy of ``specs``
    (:func:`agents.evaluation.policies.parse_policies`; ``oracle`` searches the PID's ``mu``), then with
    ``fppi_oracle`` the FPPI's ``T_r`` searched likewise (``oracle-fppi``), on ``process``."""
    commissioning = found.commissioning.controller
    results = [ProcessPolicyResult("commissioning", "commissioning", commissioning, None,
                                   process_score(process, commissioning, found, protocol))]
    for spec in specs:
        if spec.kind == "rule":
            results.append(_rule(process, found, protocol, spec.name))
        elif spec.kind == "oracle":
            results.append(_oracle(process, found, protocol, "pid", "oracle"))
        elif spec.kind == "oracle-full":
            results.append(ProcessPolicyResult("oracle-full", "oracle", error="oracle-full designs from the exact "
                                               "model of the plant, which a process does not have"))
        else:
            results.append(_agent(process, found, protocol, spec))
    if fppi_oracle:
        results.append(_oracle(process, found, protocol, "fppi", "oracle-fppi"))
    return results
