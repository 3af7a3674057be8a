"""One member of a frontier (a family at one knob, one trained seed) on a chunk of a stream's plants.

A :class:`Member` task scores one policy on plants ``first ...`` of a regime's validation or test
stream, each plant with the stream's episode seed ``episode_seed + i`` for stream plant ``i``, and writes
``DIRECTORY/per_plant.csv`` (``index, cost, feasible``): the same numbers whichever worker runs it and
whichever chunk holds the plant.  A policy is

* ``rule``: the rule family's member ``RULE@S`` (:mod:`baselines.rules.family`) on the fixed mode's
  identification, scored as :func:`agents.evaluation.run.rule_result` scores a rule;
* ``learned``: the fit in ``member`` (a learned rule, a selector or a stable-baselines3 agent) at the
  knob (:func:`agents.frontier.families.at_knob`), played in its own mode and scored in the regime
  (:func:`agents.evaluation.run.agent_result`, :func:`~agents.evaluation.run.selector_result`);
* ``oracle``: the oracle of the identified models (:func:`agents.evaluation.run.oracle_result`).

Each plant's result goes to ``DIRECTORY/cache.jsonl`` (:class:`agents.evaluation.cache.Cache`) as it is
found, so that an interrupted task resumes where it stopped; a task whose table exists is done.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["KINDS", "Member", "member_label", "score_member"]

KINDS = ("rule", "learned", "oracle")
TABLE = "per_plant.csv"


def member_label(family: str, knob: float) -> str:
    """``FAMILY@S`` (``S`` as :func:`repr` prints it: it reads back exactly)."""
    return f"{family}@{float(knob)!r}"


@dataclass(frozen=True)
class Member:
    """Plants ``first ...`` of a regime's stream (``stage``) scored for one family at one knob and one seed."""

    regime: str
    stage: str
    family: str
    kind: str
    member: str
    knob: float
    seed: str
    first: int
    env: str
    env_kwargs: dict[str, Any]
    plants: tuple[dict[str, Any], ...]
    episode_seed: int
    directory: str

    @property
    def name(self) -> str:
        seed = f" seed {self.seed}" if self.seed else ""
        return (f"{self.stage} {member_label(self.family, self.knob)}{seed} plants {self.first}-"
                f"{self.first + len(self.plants) - 1} ({self.regime})")


def _player(task: Member, env: Any) -> tuple[Any, Any, str]:
    """The played policy at the knob, the environment it plays, and its cache identity."""
    from agents.evaluation.evaluate import check_trained_on, played_env
    from agents.evaluation.policies import PolicySpec, load_agent
    from agents.frontier.families import at_knob
    from agents.training.learned_rule_policy import is_learned_rule
    from agents.training.selector_policy import is_selector
    from envs.interface import tuning_env_of

    path = task.member
    kind = "selector" if is_selector(path) else "learned-rule" if is_learned_rule(path) else "agent"
    name, policy = load_agent(PolicySpec(task.family, kind, path))
    check_trained_on(policy, task.env, f"{task.family} ({path})")
    unwrapped = tuning_env_of(env)
    scoring = {"constraints": unwrapped.constraints, "weights": unwrapped.weights, **task.env_kwargs,
               "noise_std": unwrapped.options.noise_std}
    played = played_env(policy, task.env, {**dict(getattr(policy, "env_kwargs", None) or {}), **scoring})
    return at_knob(name, policy, task.knob, played), played, f"{kind}|{path}|knob={task.knob!r}"


def _fixed_result(env: Any, kind: str, name: str, seed: int, plant: Any) -> Any:
    """A rule's or the oracle's result on the fixed mode's identification of ``plant``."""
    from agents.evaluation.run import PolicyResult, oracle_result, rule_result
    from envs.interface import episode_of

    env.reset(seed=seed, options={"plant": plant})
    episode = episode_of(env)
    experiment_time = episode.evidence.experiment_time / plant.residence_time
    if episode.identification is None:
        return PolicyResult.failed(ValueError("the identification procedure identified no usable model"), experiment_time)
    if kind == "oracle":
        return oracle_result(env, False, experiment_time)[0]
    return rule_result(env, name, experiment_time)


def score_member(task: Member) -> str:
    """Run ``task`` (module docstring); returns its folder."""
    import json

    from agents.environments import make_env
    from agents.evaluation.cache import Cache
    from agents.evaluation.run import agent_result, plant_key, selector_result
    from agents.files.writer import csv_text, write_text
    from baselines.rules.family import member_name
    from envs.interface import tuning_env_of
    from envs.systems.plants import as_plant

    directory = Path(task.directory)
    if (directory / TABLE).exists():
        return str(directory)
    if task.kind not in KINDS:
        raise ValueError(f"unknown member kind {task.kind!r} (kinds: {', '.join(KINDS)})")
    directory.mkdir(parents=True, exist_ok=True)
    cache = Cache(directory / "cache.jsonl")
    env = make_env(task.env, {"experiments": "fixed", **task.env_kwargs})
    environment = f"{task.env} {json.dumps(task.env_kwargs, sort_keys=True, default=str)}"
    family = tuning_env_of(env).family
    if task.kind == "learned":
        policy, played, identity = _player(task, env)
    else:
        policy, played = None, None
        identity = "oracle" if task.kind == "oracle" else member_name(task.member, task.knob)
    rows = [["index", "cost", "feasible"]]
    for offset, data in enumerate(task.plants):
        index, plant = task.first + offset, as_plant(dict(data))
        seed = task.episode_seed + index
        key = plant_key(environment, family, seed, index, dict(data))
        result = cache.get(key, identity)
        if result is None:
            if task.kind == "learned":
                play = selector_result if hasattr(policy, "rule_of") else agent_result
                result = play(played, policy, seed, plant)
            else:
                result = _fixed_result(env, task.kind, identity, seed, plant)
            cache.put(key, identity, result)
        rows.append([str(index), repr(float(result.cost)), str(bool(result.feasible))])
    env.close()
    if played is not None:
        played.close()
    write_text(directory / TABLE, csv_text(rows))
    return str(directory)
