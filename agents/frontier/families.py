"""The knob ``s`` of a learned policy, an agent, a Python callable and a selector (a rule's: :mod:`baselines.rules.family`).

* A policy that designs by an action (a stable-baselines3 agent, a learned rule, a callable
  ``observation -> action``): its design action ``a`` is moved so that the relative design parameter
  it maps to (``mu``, ``T_r/T_n``, ``T_r/L_n`` or ``tau_c/theta``: the environment's design map,
  ``parameter_from_action``) is multiplied by ``exp(s)``, clipped to the structure's range:
  ``a_s = action_from_parameter(parameter_from_action(a) e^s)``.  In every structure a larger
  parameter is the more conservative design (a smaller gain, a slower loop), as for the rules.  Only
  the design (the action's last component, committed on the identified model) moves; the plan's
  amplitudes and the agent mode's experiments do not.  A discrete action (MaskablePPO in the agent
  mode) has no knob.
* A selector (:mod:`agents.training.selector_policy`): its threshold on the predicted probability of
  violating, ``threshold e^{-s}``; the candidates' designs are their own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from envs.interface import tuning_env_of

__all__ = ["KnobPolicy", "KnobSelector", "at_knob"]


@dataclass
class KnobPolicy:
    """``policy`` at knob ``knob``, playing ``env`` (the environment whose design map moves its action)."""

    name: str
    policy: Any
    knob: float
    env: Any

    @property
    def env_kwargs(self) -> Any:
        return getattr(self.policy, "env_kwargs", None)

    def predict(self, observation: Any, deterministic: bool = True, **kwargs: Any) -> tuple[Any, Any]:
        action, state = self.policy.predict(observation, deterministic=deterministic, **kwargs)
        unwrapped = tuning_env_of(self.env)
        if self.knob == 0 or unwrapped.identification is None:  # no design yet (the plan's step)
            return action, state
        moved = np.array(action, dtype=np.float64).reshape(-1)
        parameter = unwrapped.parameter_from_action(float(moved[-1])) * math.exp(self.knob)
        moved[-1] = unwrapped.action_from_parameter(parameter)
        return moved.astype(np.float32), state


@dataclass
class KnobSelector:
    """A selector (:class:`agents.training.selector_policy.SelectorPolicy`) at threshold ``threshold e^{-knob}``."""

    name: str
    policy: Any
    knob: float

    @property
    def env_kwargs(self) -> Any:
        return self.policy.env_kwargs

    def choose(self, observation: Any) -> str:
        selector = self.policy.selector
        threshold = selector.threshold * math.exp(-self.knob)
        return selector.names[int(selector.choices(observation, threshold=threshold)[0])]

    def rule_of(self, choice: str) -> str | None:
        return self.policy.rule_of(choice)

    def action(self, choice: str, observation: Any) -> Any:
        return self.policy.action(choice, observation)


def at_knob(name: str, policy: Any, knob: float, env: Any) -> Any:
    """``policy`` at ``knob``: a :class:`KnobSelector` for a selector, else a :class:`KnobPolicy` on ``env``.

    Raises
    ------
    ValueError
        For a policy of a discrete action (no design parameter to move).
    """
    if hasattr(policy, "rule_of"):
        return KnobSelector(name, policy, float(knob))
    if tuning_env_of(env).discrete is not None:
        raise ValueError(f"policy {name!r} plays a discrete action (the agent mode's MaskablePPO): it has no knob")
    return KnobPolicy(name, policy, float(knob), env)
