"""The Lagrange multiplier of a risk limit, by dual ascent: the settings of a config's ``lagrangian`` key
and the update, free of stable-baselines3 (:mod:`agents.training.lagrangian` trains with them).

The constrained problem is: least expected cost subject to a violation rate at most ``risk``
(a constrained Markov decision process, Altman 1999, with one-step episodes).  Its Lagrangian
relaxation maximizes ``reward - lambda * cost`` over the policy and minimizes it over
``lambda >= 0``; the multiplier follows the projected (sub)gradient of the dual,

    lambda <- max(0, lambda + multiplier_lr * (mean cost over the last ``window`` episodes - risk)),

once per finished episode, as in the Lagrangian baselines of Ray, Achiam and Amodei (2019) and
Stooke, Achiam and Abbeel (2020, the plain, "integral-only" update).  ``lambda`` is in reward units:
a violation costs ``lambda`` more than the environment's own reward says.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

from agents.training.schema import did_you_mean, require_field, whole_number, yaml_number

__all__ = ["DualAscent", "LagrangianSettings"]


@dataclass(frozen=True)
class LagrangianSettings:
    """A config's ``lagrangian`` mapping.

    Attributes
    ----------
    risk : float
        The limit ``r`` on the violation rate, in (0, 1).
    multiplier_lr : float
        The dual step size per episode (reward units per unit of rate excess).
    initial : float
        The multiplier at the start, >= 0.
    window : int
        Episodes whose mean cost is the rate estimate of an update; updates start once it is full.
    """

    risk: float
    multiplier_lr: float = 0.1
    initial: float = 0.0
    window: int = 500

    @classmethod
    def from_mapping(cls, value: Any) -> LagrangianSettings:
        """The settings of ``value`` (a mapping of the fields); a bad key or value is a ``ValueError`` naming it."""
        require_field(isinstance(value, Mapping), "lagrangian", "a mapping (risk, multiplier_lr, initial, window)", value)
        known = [f.name for f in fields(cls)]
        for key in value:
            if key not in known:
                raise ValueError(f"unknown key lagrangian.{key}{did_you_mean(str(key), known)} (known: {', '.join(known)})")
        if "risk" not in value:
            raise ValueError("lagrangian.risk is required (the limit on the violation rate, e.g. 0.01)")
        numbers = {key: yaml_number(item) for key, item in value.items()}
        if "window" in numbers:
            numbers["window"] = whole_number(numbers["window"])
        for key in ("risk", "multiplier_lr", "initial"):
            item = numbers.get(key, 0.0)
            require_field(isinstance(item, (int, float)) and not isinstance(item, bool) and item == item,
                          f"lagrangian.{key}", "a number", item)
        settings = cls(**{key: float(item) if key != "window" else item for key, item in numbers.items()})
        require_field(0.0 < settings.risk < 1.0, "lagrangian.risk", "a number in (0, 1)", settings.risk)
        require_field(0.0 < settings.multiplier_lr < float("inf"), "lagrangian.multiplier_lr", "a positive number", settings.multiplier_lr)
        require_field(0.0 <= settings.initial < float("inf"), "lagrangian.initial", "a number >= 0", settings.initial)
        require_field(isinstance(settings.window, int) and not isinstance(settings.window, bool) and settings.window >= 1,
                      "lagrangian.window", "an integer >= 1", settings.window)
        return settings


class DualAscent:
    """The multiplier and its window of recent episode costs; :meth:`observe` one finished episode's cost.

    Attributes
    ----------
    multiplier : float
        The current ``lambda``.
    episodes : int
        Episodes observed.
    history : list of (episodes, multiplier, rate)
        One entry every ``window`` episodes (and at each update's end of a run: :meth:`record`).
    """

    def __init__(self, settings: LagrangianSettings) -> None:
        self.settings = settings
        self.multiplier = settings.initial
        self.recent: deque[float] = deque(maxlen=settings.window)
        self.episodes = 0
        self.history: list[tuple[int, float, float]] = []

    @property
    def rate(self) -> float:
        """The mean cost over the window (nan before the first episode)."""
        return sum(self.recent) / len(self.recent) if self.recent else float("nan")

    def observe(self, cost: float) -> float:
        """Take one finished episode's cost (0 or 1); once the window is full, one dual step.  Returns the multiplier."""
        self.recent.append(float(cost))
        self.episodes += 1
        if len(self.recent) == self.settings.window:
            step = self.settings.multiplier_lr * (self.rate - self.settings.risk)
            self.multiplier = max(0.0, self.multiplier + step)
        if self.episodes % self.settings.window == 0:
            self.record()
        return self.multiplier

    def record(self) -> None:
        """Append ``(episodes, multiplier, rate)`` to :attr:`history` (once per episode count)."""
        if not self.history or self.history[-1][0] != self.episodes:
            self.history.append((self.episodes, self.multiplier, self.rate))
