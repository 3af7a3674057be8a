"""The families of ``deadtime frontier --policies``: a comma-separated list, each item one of

* a rule name of :data:`baselines.rules.registry.RULES` (its family: :mod:`baselines.rules.family`), or
  ``all-rules``: every rule of the environment's structure (:func:`agents.evaluation.policies.applicable_rules`);
* ``learned-<structure>@<risk>`` or ``NAME=learned-pid@0.01``: a shipped risk-conditioned learner at a risk
  (:mod:`agents.risk.pretrained`), its knob moving its design as a learned rule's;
* ``module:function`` or ``NAME=module:function``: a Python callable ``observation -> action``, imported
  from the working directory or ``sys.path`` (it runs the module's code: name only your own);
* ``PATH`` or ``NAME=PATH``: a stable-baselines3 agent, a learned rule or a selector, as ``deadtime
  evaluate`` loads them (:func:`agents.evaluation.policies.load_agent`; loading an agent runs pickled
  code from its folder: load only agents you trust).  ``PATH`` may be a glob pattern
  (``NAME=runs/sac-seed*``): each match is one seed's trained model of one family.
"""

from __future__ import annotations

import glob
import os
import re
from typing import Any

from agents.frontier.frontier import RULE, Family
from agents.user_code import user_function

__all__ = ["parse_families"]

_CALLABLE = re.compile(r"[A-Za-z_][\w.]*:[A-Za-z_]\w*")
_KINDS = {"agent": "agent", "learned-rule": "learned rule", "selector": "selector"}


def parse_families(text: str, structure: str | None = None) -> list[Family]:
    """The families of ``--policies`` (module docstring), in order.

    Raises
    ------
    ValueError
        One line naming the item: empty, an unknown rule, a module that cannot be imported, a name that
        is no function, a path that matches nothing, or an agent that cannot be loaded.
    """
    items = [item.strip() for item in str(text).split(",")]
    if not str(text).strip() or any(not item for item in items):
        raise ValueError(f"--policies must be a comma-separated list of policies, got {text!r}")
    if "all-rules" in items:
        from agents.evaluation.policies import applicable_rules

        if structure is None:
            raise ValueError("--policies: all-rules needs the environment's structure")
        at = items.index("all-rules")
        items[at:at + 1] = [rule for rule in applicable_rules(structure) if rule not in items]
    return [_family(item) for item in items]


def _family(item: str) -> Family:
    from agents.risk.pretrained import is_pretrained_name
    from baselines.rules.registry import RULES, get_rule

    name, _, target = item.rpartition("=")
    if target in RULES:
        return Family(name or target, RULE, (target,))
    if is_pretrained_name(target):
        return _pretrained(name, target)
    if _CALLABLE.fullmatch(target) and not os.path.exists(target):
        return Family(name or target.rpartition(":")[2], "callable", (_callable(target),), (None,))
    if "=" in item or os.sep in target or glob.has_magic(target) or os.path.exists(target):
        return _loaded(name, target)
    get_rule(item)  # raises: unknown rule, naming the closest
    raise ValueError(f"unknown policy {item!r}")


def _callable(target: str) -> Any:
    from agents.evaluation.policies import CallablePolicy

    function = user_function(target, "--policies")
    return CallablePolicy(target.partition(":")[2], function)


def _pretrained(name: str, target: str) -> Family:
    """The family of one shipped learner at a risk (one member: it is not trained per seed)."""
    from agents.evaluation.evaluate import identity
    from agents.evaluation.policies import PolicySpec, load_agent

    spec = PolicySpec(target, "learned-rule", target)
    _, policy = load_agent(spec)
    return Family(name or target, "learned rule", (policy,), (identity(spec, policy, dict(policy.env_kwargs)),))


def _loaded(name: str, pattern: str) -> Family:
    """One family of the trained models ``pattern`` matches (one per seed), all of one kind."""
    from agents.evaluation.evaluate import identity
    from agents.evaluation.policies import PolicySpec, load_agent
    from agents.training.learned_rule_policy import is_learned_rule
    from agents.training.selector_policy import is_selector

    paths = sorted(glob.glob(pattern)) if glob.has_magic(pattern) else [pattern]
    if not paths:
        raise ValueError(f"--policies: {pattern!r} matches no file")
    members, identities, kinds = [], [], set()
    for path in paths:
        kind = "selector" if is_selector(path) else "learned-rule" if is_learned_rule(path) else "agent"
        spec = PolicySpec(name, kind, path)
        own, policy = load_agent(spec)
        name = name or own
        members.append(policy)
        identities.append(identity(spec, policy, dict(getattr(policy, "env_kwargs", None) or {})))
        kinds.add(kind)
    if len(kinds) > 1:
        raise ValueError(f"--policies: {pattern!r} matches models of different kinds ({', '.join(sorted(kinds))})")
    return Family(name, _KINDS[kinds.pop()], tuple(members), tuple(identities))
