"""Policies on a process: the commissioning controller, the rules, the process oracle and agents.

Every policy reads the same experiments (:func:`envs.process.procedure.identify_process`) and gives
a controller, which :func:`envs.process.scoring.process_score` tests on the process itself and
judges on the identified model:

* ``commissioning``: the loop's existing controller (given or designed from the first step);
* a rule: ``rule(RuleInputs.from_identification(identification))``, as ``deadtime evaluate`` and
  ``deadtime tune`` design it (:mod:`baselines.rules.registry`);
* ``oracle``: :func:`baselines.process_oracle.process_oracle`, the PID's ``mu`` searched with process
  runs (``oracle-fppi``: the FPPI's ``T_r``);
* an agent, a learned rule or a selector trained in a fixed-mode or plan-mode environment of a
  self-regulating structure (any version, ``PID-v0`` to ``PID-v3``, ``FPPI``, ``PI``): its observation is
  built from the process's experiments as its environment builds it after the fixed procedure
  (:func:`process_observation`: :func:`envs.episode.evidence_from_identification` with the
  environment's options, then :meth:`envs.tuning_env.DeadTimeTuningEnv.observe`: the features, the
  design features of v1-v3, the failed experiments and, in plan mode, the pending design step).  In
  v3 (``measured_observation``) the noise level is estimated from the closed-loop step's record as in
  simulation, over the set-point step; in v0-v2 the noise ratio is the procedure's measured
  ``sigma/|setpoint_step|``.  Its action is mapped to the parameter by the environment's own
  ``parameter_from_action``, and the controller is the environment's design on the identified model;
  a selector's choice is played as a rule (by name) or its learned design's action.  A plan-mode
  agent's experiment amplitudes are not applied: the process runs its own procedure.

  **Out of distribution**: the observation's plant features (:data:`CHECKED_FEATURES`) are compared
  with their range over :data:`FAMILY_PLANTS` plants of the environment's training family, identified
  as in training (the 0.5% and 99.5% quantiles); a feature outside is named in the result's note, and
  the policy is still played.

A policy that cannot give a controller here (a rule undefined for these inputs, a controller with
no discrete law, an agent of the agent mode) is a failure with its reason, not an error of the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from envs.interface import tuning_env_of
from envs.process.performance import RunProtocol
from envs.process.procedure import ProcessIdentification
from envs.process.protocol import Process
from envs.process.scoring import ProcessScore, process_score

__all__ = ["CHECKED_FEATURES", "FAMILY_PLANTS", "ProcessPolicyResult", "evaluate_policies",
           "out_of_distribution", "process_observation", "DEFAULT_AGENT_ENV", "RANGE_QUANTILES"]

DEFAULT_AGENT_ENV = "DeadTime/PID-v0"
"""The environment of an agent saved without its config (it is then taken as a PID-v0 agent)."""
CHECKED_FEATURES: tuple[str, ...] = ("tau", "theta", "dead_time_fraction", "log_mismatch", "log_noise_ratio",
                                     "log_base_parameter", "check_ms", "check_delay_margin")
"""The observation's features that describe the plant and its noise, checked against the training family."""
FAMILY_PLANTS = 400
"""Plants of the training family whose observations give the features' training range."""
RANGE_QUANTILES = (0.005, 0.995)
"""The quantiles of a feature over the training plants that bound its training range."""


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
    note: str | None = None


def process_observation(env: Any, found: ProcessIdentification) -> np.ndarray:
    """The observation ``env`` (unwrapped) shows after its fixed procedure, of the process's experiments
    (module docstring)."""
    from dataclasses import replace

    from envs.episode import evidence_from_identification

    if env.options.measured:  # the noise estimate knows the process's sensor resolution (output units, as the records)
        options = replace(env.options, quantization=found.quantization)
        evidence = evidence_from_identification(found.identification, options, abs(found.setpoint_step))
    else:
        evidence = evidence_from_identification(found.identification, replace(env.options, noise_std=found.noise_ratio))
    return env.observe(found.identification, evidence)


_RANGES: dict[str, dict[str, tuple[float, float]]] = {}


def _training_ranges(env_id: str, kwargs: dict[str, Any]) -> dict[str, tuple[float, float]]:
    """Each checked feature's range over the training family's plants (module docstring), cached per environment."""
    import json

    from agents.environments import make_env

    key = json.dumps([env_id, kwargs], sort_keys=True, default=str)
    if key not in _RANGES:
        env = make_env(env_id, {**kwargs, "experiments": "fixed"})
        names = tuning_env_of(env).feature_names
        rows = np.array([env.reset(seed=k)[0] for k in range(FAMILY_PLANTS)])
        env.close()
        _RANGES[key] = {name: tuple(float(q) for q in np.quantile(rows[:, names.index(name)], RANGE_QUANTILES))
                        for name in CHECKED_FEATURES if name in names}
    return _RANGES[key]


def out_of_distribution(env_id: str, kwargs: dict[str, Any], names: tuple[str, ...], observation: np.ndarray,
                        ranges: dict[str, Any] | None = None) -> str | None:
    """A note naming the observation's features outside the training range, or None: ``ranges`` where the policy
    carries its own (a shipped learner, trained across regimes), else the training family's."""
    outside = []
    for name, (low, high) in (ranges or _training_ranges(env_id, kwargs)).items():
        value = float(observation[names.index(name)])
        if not low <= value <= high:
            outside.append(f"{name} {value:.3g} outside [{low:.3g}, {high:.3g}]")
    return None if not outside else "out of distribution: " + "; ".join(outside)


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
    from dataclasses import replace

    from agents.environments import make_env
    from agents.evaluation.policies import load_agent
    name, policy = load_agent(spec)  # a file that cannot be loaded is bad input (one line, exit 2)
    env_id = getattr(policy, "env_id", None) or DEFAULT_AGENT_ENV
    kwargs = dict(getattr(policy, "env_kwargs", {}) or {})
    env = tuning_env_of(make_env(env_id, kwargs))
    if env.mode == "agent":
        return ProcessPolicyResult(name, "agent", error=f"the agent plays {env_id} in agent mode (it chooses its experiments); "
                                   "on a process the fixed procedure runs, so only fixed- and plan-mode agents apply")
    if env.kind.integrating:
        return ProcessPolicyResult(name, "agent", error=f"the agent designs the modified Smith predictor of {env_id}, for "
                                   "integrating plants; the procedure here identifies self-regulating processes")
    observation = process_observation(env, found)
    note = out_of_distribution(env_id, kwargs, env.feature_names, observation, getattr(policy, "feature_ranges", None))
    if hasattr(policy, "choose"):  # a selector: a rule by name, or its learned design's action
        choice = policy.choose(observation)
        rule = policy.rule_of(choice)
        note = "; ".join(filter(None, [f"chose {choice}", note]))
        if rule is not None:
            return replace(_rule(process, found, protocol, rule), name=name, role="agent", note=note)
        action = policy.action(choice, observation)
    else:
        action, _ = policy.predict(observation, deterministic=True)
    relative = env.parameter_from_action(float(np.asarray(action, dtype=np.float64).reshape(-1)[-1]))
    controller = env.kind.relative_design(env.kind.model_of(found.identification), relative)
    try:
        return ProcessPolicyResult(name, "agent", controller, relative, process_score(process, controller, found, protocol), note=note)
    except ValueError as error:
        return ProcessPolicyResult(name, "agent", controller, relative, error=str(error), note=note)


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
