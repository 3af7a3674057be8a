"""The cost of one frontier evaluation (one family at one knob, one seed, one plant), and the share of it
spent identifying the plant: ``deadtime protocol frontier-cost ENV [--plants N] [--fit RUN_DIR]``.

Per plant of the fixed validation set, with its episode seed: the fixed mode's episode reset (the
identification experiments and the fit of the models, which do not depend on the policy), a rule's
design and score on that identification, the oracle's, and (with ``--fit``) a learned policy's whole
episode at a knob (its own reset, then its design).  A frontier run scores a rule family's knobs on
one identification per plant (:class:`agents.protocol.members.Knobs`): a rule member costs its design
and score, the reset once per plant and family; a learned member plays its own episode, reset included.
"""

from __future__ import annotations

import time
from typing import Any

__all__ = ["measure"]


def measure(env_id: str, plants: int = 20, env_kwargs: dict[str, Any] | None = None, fit: str | None = None,
            rule: str = "amigo-pid", seed: int = 70000000) -> dict[str, Any]:
    """Mean CPU seconds (this process) per plant of each step (module docstring)."""
    from agents.environments import make_env
    from agents.evaluation.run import agent_result, oracle_result, rule_result
    from envs.interface import episode_of, tuning_env_of
    from envs.systems.plant_sets import plant_set

    env_kwargs = dict(env_kwargs or {})
    env = make_env(env_id, {"experiments": "fixed", **env_kwargs})
    family = tuning_env_of(env).family
    found = {"reset": 0.0, "rule": 0.0, "oracle": 0.0, "learned_episode": 0.0}
    player = played = None
    if fit is not None:
        from agents.protocol.members import Member, _player

        task = Member("", "", "learned", "learned", fit, 0.5, "0", 0, env_id, env_kwargs, (), 0, "")
        player, played, _ = _player(task, env)
    sample = plant_set(family, "validation", plants)
    env.reset(seed=seed, options={"plant": sample[0]})  # compiled kernels loaded before the clock starts
    for i, plant in enumerate(sample):
        start = time.process_time()
        env.reset(seed=seed + i, options={"plant": plant})
        found["reset"] += time.process_time() - start
        experiment_time = episode_of(env).evidence.experiment_time / plant.residence_time
        start = time.process_time()
        rule_result(env, f"{rule}@0.5", experiment_time)
        found["rule"] += time.process_time() - start
        start = time.process_time()
        oracle_result(env, False, experiment_time)
        found["oracle"] += time.process_time() - start
        if player is not None:
            start = time.process_time()
            agent_result(played, player, seed + i, plant)
            found["learned_episode"] += time.process_time() - start
    per_plant = {name: value / plants for name, value in found.items()}
    rule_total = per_plant["reset"] + per_plant["rule"]
    result = {"env": env_id, "env_kwargs": env_kwargs, "plants": plants, "seconds_per_plant": per_plant,
              "rule_evaluation_seconds": rule_total, "identification_share_of_rule_evaluation": per_plant["reset"] / rule_total}
    if player is not None:
        result["identification_share_of_learned_evaluation"] = per_plant["reset"] / per_plant["learned_episode"]
    return result
