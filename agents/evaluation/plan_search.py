"""``plan-best``: the single plan of experiment amplitudes that is best on the validation plants.

Every plan of :data:`PLAN_GRID` (the closed-loop step's amplitude times the second experiment's) is
played by :class:`baselines.procedures.PlanRule` on the first :data:`VALIDATION_PLANTS` validation
plants of the environment's family, in the evaluation's regime, as ``deadtime train`` validates an
agent (:func:`agents.training.validation.validate_policy`: seed ``3_000_000 + k`` for plant ``k``).
The plan of the least mean cost is chosen (ties: the smaller amplitudes), and only then played on
the test plants: a "plan rule", the best that choosing experiments without looking at the plant can
do, against which a per-plant choice is measured.
"""

from __future__ import annotations

import itertools
import sys
from typing import Any

__all__ = ["PLAN_GRID", "VALIDATION_PLANTS", "best_plan"]

PLAN_GRID: tuple[float, ...] = (0.1, 0.3, 1.0, 3.0)
"""The amplitudes tried for each of the two experiments (3 is the v2-v3 amplitude limit)."""
VALIDATION_PLANTS = 60


def best_plan(env_id: str, kwargs: dict[str, Any], plants: int = VALIDATION_PLANTS) -> tuple[Any, dict[str, float]]:
    """The best plan on the validation plants, and every plan's validation mean cost by name.

    ``kwargs`` are the plan environment's arguments (the procedure's interface and the evaluation's
    scoring)."""
    from agents.environments import make_env
    from agents.training.validation import validate_policy, validation_plants
    from baselines.procedures import PlanRule

    env = make_env(env_id, kwargs)
    chosen = validation_plants(env, plants)
    plans = [PlanRule(first, second) for first, second in itertools.product(PLAN_GRID, PLAN_GRID)]
    costs = {plan.name: validate_policy(lambda observation, plan=plan: plan.predict(observation)[0], env, len(chosen),
                                        chosen).mean_cost for plan in plans}
    best = min(plans, key=lambda plan: (costs[plan.name], plan.first))
    name = best.name
    print(f"plan-best on {env_id}: {best.name} (validation mean cost {costs[name]:.4g} on {len(chosen)} plants; "
          f"plan-1-1 {costs['plan-1-1']:.4g})", file=sys.stderr, flush=True)
    return best, costs
