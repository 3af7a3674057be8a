"""The 80 test plants of an environment in fixed mode under environment arguments: experiment
time and deviation (in true T_ar), and the mean costs of a rule and of the oracle on the identified model.
Episode i is ``reset(seed=i, options={"plant": test plant i})``, as ``deadtime evaluate --seed 0`` plays it.

Usage: deadtime study noise-kinds '{"disturbances": {"drift": 0.005}}' 0.01,0.05
           [--env DeadTime/FPPI-v0] [--rule fppi-eq34] [--no-oracle]
Results: docs/environments/overview.md, "Experiments with a price, disturbances, least squares".
"""

from __future__ import annotations

import json
import time

import gymnasium as gym
import numpy as np

import envs  # noqa: F401
from baselines.oracle import oracle
from baselines.rules.registry import RuleInputs, get_rule
from envs.identification.procedure import experiment_deviation
from envs.systems.plant_sets import plant_set


def noise_kinds(kwargs: dict, noises: str = "0.01,0.05,0.1,0.2", env_id: str = "DeadTime/FPPI-v0", rule_name: str = "fppi-eq34",
                no_oracle: bool = False, n: int = 80) -> None:
    """Print one JSON line per noise level (comma-separated ``noises``) of ``env_id`` made with ``kwargs``."""
    rule = get_rule(rule_name)
    for noise in [float(x) for x in noises.split(",")]:
        env = gym.make(env_id, noise_std=noise, **kwargs).unwrapped
        plants = plant_set("integrating" if env.integrating else "stable", "test", n)
        times, deviations, costs, best, failed = [], [], [], [], 0
        started = time.time()
        for i, plant in enumerate(plants):
            try:
                env.reset(seed=i, options={"plant": plant})
            except ValueError:  # no usable closed-loop step (strong disturbances)
                failed += 1
                continue
            found = env.identification
            times.append(found.experiment_time / plant.residence_time)
            deviation = experiment_deviation(found.closed_loop) + experiment_deviation(found.open_loop)  # tracked or not
            deviations.append(deviation / plant.residence_time)
            costs.append(env.score_controller(rule(RuleInputs.from_identification(found))).cost)
            if not no_oracle:
                best.append(oracle(plant, found, env.structure, constraints=env.constraints, weights=env.weights).cost)
        print(json.dumps({
            "env": env_id, "noise": noise, "kwargs": kwargs, "experiment_time": np.mean(times),
            "deviation": np.mean(deviations), rule_name: np.mean(costs), f"{rule_name}_median": float(np.median(costs)),
            f"{rule_name}_infeasible": int(np.sum(np.array(costs) > 20)), "oracle": np.mean(best) if best else None,
            "failed": failed, "seconds": round(time.time() - started),
        }), flush=True)
