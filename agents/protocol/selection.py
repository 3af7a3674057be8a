"""Choices on the validation plants: the primaries, the best rule and the best single plan.

Only validation plants decide; the test plants are evaluated after every choice is written.

* The best rule (and the best plan): the least mean validation cost among the declared rules (plans).
* A primary, among a regime's candidate learners of one mode: each candidate's per-plant cost is its
  mean over the seeds, and its certificate the exact upper bound (:func:`agents.protocol.statistics.clopper_pearson`
  at the declared confidence, two-sided) on the share of validation plants where it violates in any
  seed.  The primary is the candidate of least mean validation cost among those whose upper bound is
  at most the violation target; when none is, the candidate of least upper bound (then least mean cost).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.protocol.statistics import plant_means, plant_violations

__all__ = ["Candidate", "choose_primary", "least_mean"]


@dataclass(frozen=True)
class Candidate:
    """One candidate's validation record."""

    label: str
    mean_cost: float
    violating_plants: int
    plants: int
    upper_bound: float
    certified: bool

    def to_dict(self) -> dict[str, Any]:
        return {"label": self.label, "mean_cost": self.mean_cost, "violating_plants": self.violating_plants,
                "plants": self.plants, "violation_upper_bound": self.upper_bound, "certified": self.certified}


def least_mean(costs: dict[str, np.ndarray]) -> str:
    """The name of least mean cost (ties: the first in order) among ``costs`` (per-plant arrays)."""
    if not costs:
        raise ValueError("nothing to choose from")
    return min(costs, key=lambda name: float(np.mean(costs[name])))


def choose_primary(costs: dict[str, np.ndarray], feasible: dict[str, np.ndarray], target: float,
                   confidence: float) -> tuple[str, list[Candidate]]:
    """The primary among candidates (``(seeds, plants)`` costs and feasibility by label) and every record."""
    records = []
    for label in costs:
        violations = plant_violations(feasible[label], confidence)
        upper = violations.interval[1]
        records.append(Candidate(label, float(plant_means(costs[label]).mean()), violations.violating, violations.plants,
                                 upper, upper <= target))
    if not records:
        raise ValueError("a primary needs at least one candidate")
    certified = [record for record in records if record.certified]
    if certified:
        chosen = min(certified, key=lambda record: record.mean_cost)
    else:
        chosen = min(records, key=lambda record: (record.upper_bound, record.mean_cost))
    return chosen.label, records
