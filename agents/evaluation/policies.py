"""The policies of ``deadtime evaluate``: parsing ``--policies`` and the rules of a structure.

A policy is one of

* a rule name of :data:`baselines.rules.registry.RULES`;
* ``all-rules``: the rules of the environment's own structure and every PI/PID rule of the
  literature (the Gorez-Klan ``mu`` rules included), among those that apply to the environment's
  plants (self-regulating in ``PID-v0`` and ``FPPI-v0``, integrating in ``MSP-v0``; rules marked
  ``both`` count for either).  The ``T_r`` rules of the other dead-time compensator are left out
  (the FPPI rules in ``PID-v0``): they tune a different controller class, and they can still be
  named one by one.  (On the PID-v0 test set ``fppi-eq34`` beats even the PID oracle, the limit of
  the PID structure itself: 1.99 against 2.25 at n = 30.)
* ``oracle``: :func:`baselines.oracle.oracle` on the identified data of the episode;
* ``oracle-full``: :func:`baselines.oracle.full_information_oracle` (exact model, no experiment);
* a path to a saved agent, loaded by ``agents.training.policies.load_policy``, or ``NAME=PATH`` to name it
  in the tables (default: the loaded policy's ``name``).  Loading executes nothing from the agent's
  folder: its files are checked against their manifest, its parameters read as tensors and its
  statistics as JSON, the algorithm rebuilt from the run's config;
* a path to a learned rule (``PATH`` or ``NAME=PATH``: the run directory of a ``learned-rule`` fit, or
  its ``learned_rule.json``; :mod:`agents.training.learned_rule`), recognized by its files and loaded
  by ``agents.training.learned_rule_policy.load_learned_rule``.  It plays like an agent (one action
  from the observation) and has the role ``learned rule`` in the tables;
* a path to a selector (``PATH`` or ``NAME=PATH``: the run directory of a ``selector`` fit,
  :mod:`agents.training.selector`; unnamed, its name starts with ``selector``), loaded by
  ``agents.training.selector_policy.load_selector``.  Per plant it chooses a candidate from the
  observation and plays it (:func:`agents.evaluation.run.selector_result`); it has the role
  ``selector``, and the results give the share of plants given to each candidate;
* ``learned-<structure>@<risk>``: a shipped risk-conditioned learner of the structure (``pid``,
  ``fppi``, ``msp``, ``pi``) at the risk ``r`` in (0, 0.5), e.g. ``learned-pid@0.01``
  (:mod:`agents.risk.pretrained`); it plays like a learned rule, in the fixed mode of its v3 environment;
* a procedure of :mod:`baselines.procedures`: ``plan-A1-A2`` (the fixed procedure's two experiments at
  amplitudes ``A1`` and ``A2`` for every plant, then the structure's base rule; ``plan-1-1`` is the
  fixed procedure), ``plan-best`` (the plan of the least mean cost on the validation plants in the
  evaluation's regime: :mod:`agents.evaluation.plan_search`) or ``amplitude-rule`` (Marlin's
  signal-to-noise guideline from the measured noise).  It plays like an agent, in its own mode, and has the role ``procedure``.

From Python (:func:`agents.evaluation.evaluate.evaluate`), the policies may also be a list whose items
are such strings, Python policies or mappings of names to Python policies (:func:`split_policies`).  A
Python policy is a callable ``observation -> action`` (:class:`CallablePolicy`) or an object with
stable-baselines3's ``predict(observation, deterministic=True)`` (a model trained in the same
session); it plays like an agent, with the role ``agent``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["PLAYED", "ROLES", "STRUCTURE_CONTROLLER", "TRAINED", "CallablePolicy", "PolicySpec", "applicable_rules", "load_agent",
           "own_rules", "parse_policies", "split_policies"]

from envs.structures import STRUCTURES

STRUCTURE_CONTROLLER = {name: s.controller for name, s in STRUCTURES.items()}
"""The controller type of each environment structure's design (the rules of its own structure)."""


TRAINED = ("agent", "learned-rule", "selector")
"""The kinds of policy loaded from a path and played from the observation."""

PLAYED = (*TRAINED, "procedure")
"""The kinds of policy that play episodes of their own (the others design on the fixed mode's
identification)."""

ROLES = {"agent": "agent", "learned-rule": "learned rule", "selector": "selector", "procedure": "procedure"}
"""The role in the tables of each kind of :data:`PLAYED`."""


@dataclass(frozen=True)
class PolicySpec:
    """One policy to evaluate: ``kind`` is ``"rule"``, ``"oracle"``, ``"oracle-full"``, ``"agent"``,
    ``"learned-rule"``, ``"selector"`` or ``"procedure"``."""

    name: str
    kind: str
    path: str | None = None


@dataclass(frozen=True)
class CallablePolicy:
    """A policy given in Python: ``function(observation) -> action``, played like an agent.

    ``env_kwargs`` are the arguments of the environment it plays (e.g. ``{"experiments": "agent"}``
    for the agent mode; default the environment's own), under the evaluation's regime.
    """

    name: str
    function: Callable[[Any], Any]
    env_kwargs: Mapping[str, Any] | None = None

    def predict(self, observation: Any, deterministic: bool = True) -> tuple[Any, None]:
        """``(function(observation), None)``, the form of stable-baselines3's ``predict``."""
        return self.function(observation), None


_POLICY_FORMS = ("a policy name (rule, all-rules, oracle, agent path, ...), a callable observation -> action, "
                 "an object with predict(observation, deterministic=True), or a mapping of names to those two")


def _python_policy(policy: Any, name: str) -> Any:
    """``policy`` ready to play: an object with ``predict`` as it is, a callable in a :class:`CallablePolicy`."""
    return policy if hasattr(policy, "predict") else CallablePolicy(name, policy)


def _own_name(policy: Any, position: int) -> str:
    """The name of a Python policy given without one: its ``name`` or ``__name__`` (not ``<lambda>``),
    else ``policy-<position>``."""
    for attribute in ("name", "__name__"):
        name = getattr(policy, attribute, None)
        if isinstance(name, str) and name and not name.startswith("<"):
            return name
    return f"policy-{position}"


def split_policies(policies: Any) -> tuple[str | None, dict[str, Any]]:
    """The policy strings of ``policies`` joined by commas (None if none), and its Python policies by name.

    ``policies`` is a comma-separated string (``--policies``), a mapping of names to Python policies,
    or a list of strings, Python policies and such mappings (module docstring).

    Raises
    ------
    ValueError
        For an item of another kind, a name that is not a non-empty string, or a name given twice.
    """
    if isinstance(policies, str):
        return policies, {}
    items = [policies] if isinstance(policies, Mapping) else policies
    if not isinstance(items, list | tuple) or not items:
        raise ValueError(f"policies must be a non-empty string or list: {_POLICY_FORMS}; got {policies!r}")
    texts: list[str] = []
    python: dict[str, Any] = {}
    for index, item in enumerate(items):
        if isinstance(item, str):
            texts.append(item)
            continue
        named = item.items() if isinstance(item, Mapping) else [(_own_name(item, index), item)]
        for name, policy in named:
            if not isinstance(name, str) or not name.strip() or "," in name:
                raise ValueError(f"policies[{index}]: a policy's name must be a non-empty string without commas, got {name!r}")
            if name in python:
                raise ValueError(f"policy name {name!r} is given twice; name the policies with a mapping {{name: policy}}")
            if not (callable(policy) or hasattr(policy, "predict")):
                raise ValueError(f"policies[{index}] must be {_POLICY_FORMS}; got {type(policy).__name__}")
            python[name] = _python_policy(policy, name)
    return (",".join(texts) if texts else None), python


def applicable_rules(structure: str) -> list[str]:
    """Names of the rules for the plants of an environment of ``structure`` (``all-rules``):
    :func:`baselines.rules.registry.applicable_rules`."""
    from baselines.rules.registry import applicable_rules as rules_for

    return rules_for(structure)


def own_rules(structure: str) -> list[str]:
    """Names of the rules that set the environment's own design parameter (``mu``, ``T_r``, or the PI's
    ``tau_c``: its base rule ``simc-pi`` and that rule matched to ``Ms`` targets, ``simc-pi-msX``).

    These, and only these, compete for "paper rule", the reference of the gap closure: the oracle is the
    per-plant optimum of that structure's one parameter, so a rule of another structure (a full
    PID, or the FPPI in ``PID-v0``) is not bounded by it and the gap would not be a share of
    anything.
    """
    from baselines.rules.registry import RULES

    controller, base = STRUCTURE_CONTROLLER[structure], STRUCTURES[structure].base_rule
    return [name for name, rule in RULES.items()
            if rule.controller == controller and (rule.parameter is not None or name in (base, *_matched(base)))]


def _matched(rule: str) -> list[str]:
    """The names of ``rule`` matched to the ``Ms`` targets (:data:`baselines.rules.registry.MS_TARGETS`)."""
    from baselines.rules.registry import MS_TARGETS

    return [f"{rule}-ms{target:g}" for target in MS_TARGETS]


def parse_policies(text: str, structure: str) -> list[PolicySpec]:
    """The policies of a comma-separated ``--policies`` value, in order, without duplicates.

    Raises
    ------
    ValueError
        For an empty list or an unknown rule or policy (the message names it and the closest
        name).  Agent paths are checked
        when loaded (:func:`load_agent`).
    """
    from agents.risk.pretrained import is_pretrained_name, parse_name
    from baselines.procedures import is_procedure, procedure
    from baselines.rules.registry import RULES, get_rule

    items = [item.strip() for item in text.split(",")]
    if not text.strip() or any(not item for item in items):
        raise ValueError(f"--policies must be a comma-separated list of policies, got {text!r}")
    specs: list[PolicySpec] = []
    for item in items:
        if item == "all-rules":
            specs += [PolicySpec(name, "rule") for name in applicable_rules(structure)]
        elif item in ("oracle", "oracle-full"):
            specs.append(PolicySpec(item, item))
        elif is_pretrained_name(item):  # a shipped learner at a risk, learned-pid@0.01 (agents.risk.pretrained)
            parse_name(item)  # raises: unknown structure, a risk outside (0, 0.5)
            specs.append(PolicySpec(item, "learned-rule", item))
        elif item in RULES or ("@" in item and get_rule(item)):  # a rule, or a member RULE@S of its family
            specs.append(PolicySpec(item, "rule"))
        elif is_procedure(item):
            procedure(item)  # raises: amplitudes out of range
            specs.append(PolicySpec(item, "procedure"))
        elif "=" in item or os.sep in item or item.endswith(".zip") or os.path.exists(item):
            name, _, path = item.rpartition("=")
            if not path:
                raise ValueError(f"policy {item!r} names no agent path after '='")
            from agents.training.learned_rule_policy import is_learned_rule
            from agents.training.selector_policy import is_selector

            kind = "selector" if is_selector(path) else "learned-rule" if is_learned_rule(path) else "agent"
            specs.append(PolicySpec(name, kind, path))  # name "" -> the policy's own name
        else:
            _unknown(item)
    unique: dict[tuple[str, str | None], PolicySpec] = {}
    for spec in specs:
        unique.setdefault((spec.name, spec.path), spec)
    return list(unique.values())


_KEYWORDS = ("all-rules", "oracle", "oracle-full", "plan-best", "amplitude-rule")
"""The policy names that are not rules (besides ``plan-A1-A2`` and paths)."""


def _unknown(item: str) -> None:
    """Refuse a policy that is neither a rule nor any other kind, naming the closest name."""
    import difflib

    from baselines.rules.registry import RULES, get_rule

    close = difflib.get_close_matches(item, [*_KEYWORDS, *RULES], n=1)
    if close and close[0] in _KEYWORDS:
        raise ValueError(f"unknown policy {item!r} (did you mean {close[0]!r}?): policies are rule names, "
                         f"{', '.join(_KEYWORDS)}, plan-A1-A2 or agent paths")
    get_rule(item)  # raises: unknown rule, naming the closest


def load_agent(spec: PolicySpec) -> tuple[str, Any]:
    """``(name, policy)`` of an agent spec, through ``agents.training.policies.load_policy``, or of a
    learned rule, through ``agents.training.learned_rule_policy.load_learned_rule``.

    Raises
    ------
    ValueError
        If the agent cannot be loaded (the message names the path).
    """
    if spec.kind == "procedure":
        from baselines.procedures import procedure

        return spec.name, procedure(spec.name)
    if spec.kind == "learned-rule" and spec.path == spec.name:  # a shipped learner by name (parse_policies)
        from agents.risk.pretrained import is_pretrained_name, load_pretrained

        if is_pretrained_name(spec.name):
            return spec.name, load_pretrained(spec.name)
    if spec.kind == "learned-rule":
        from agents.training.learned_rule_policy import load_learned_rule

        policy = load_learned_rule(spec.path)
        return spec.name or policy.name, policy
    if spec.kind == "selector":
        from agents.training.selector_policy import load_selector

        policy = load_selector(spec.path)
        return spec.name or (policy.name if policy.name.startswith("selector") else f"selector-{policy.name}"), policy
    try:
        from agents.training.policies import load_policy, resolve_model_path
    except ImportError as error:
        raise ValueError(f"cannot load agent {spec.path!r}: agents.training.policies is not available ({error})") from None
    try:
        resolve_model_path(spec.path)  # a missing or unreadable file is named before torch is imported
        policy = load_policy(spec.path)
    except ValueError:
        raise
    except (OSError, KeyError, RuntimeError, EOFError) as error:
        raise ValueError(f"cannot load agent {spec.path!r}: {error}") from None
    return spec.name or str(getattr(policy, "name", "agent")), policy
