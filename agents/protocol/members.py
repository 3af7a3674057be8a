"""One member of a frontier (a family at one knob, one trained seed) on a chunk of a stream's plants.

A :class:`Member` task scores one policy on plants ``first ...`` of a regime's validation or test
stream, each plant with the stream's episode seed ``episode_seed + i`` for stream plant ``i``, and writes
``DIRECTORY/per_plant.csv`` (``index, cost, feasible``): the same numbers whichever worker runs it and
whichever chunk holds the plant.  A policy is

* ``rule``: the rule family's member ``RULE@S`` (:mod:`baselines.rules.family`) on the fixed mode's
  identification, scored as :func:`agents.evaluation.run.rule_result` scores a rule;
* ``learned``: the fit in ``member`` (a learned rule, a selector or a stable-baselines3 agent), or the
  shipped learner ``member`` names (``learned-pid@0.01``, :mod:`agents.risk.pretrained`), at the
  knob (:func:`agents.frontier.families.at_knob`), played in its own mode and scored in the regime
  (:func:`agents.evaluation.run.agent_result`, :func:`~agents.evaluation.run.selector_result`);
* ``oracle``: the oracle of the identified models (:func:`agents.evaluation.run.oracle_result`).

Each plant's result goes to ``DIRECTORY/cache.jsonl`` (:class:`agents.evaluation.cache.Cache`) as it is
found, so that an interrupted task resumes where it stopped; a task whose table exists is done.  A task
adds its CPU and wall seconds to ``DIRECTORY/timing.json`` (a batch of knobs, to its first member's).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["KINDS", "TIMING", "Knobs", "Member", "batched", "clock", "member_label", "score_knobs", "score_member", "timed"]

KINDS = ("rule", "learned", "oracle")
TABLE = "per_plant.csv"
TIMING = "timing.json"


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


def _loaded(task: Member, env: Any) -> tuple[str, Any, Any, str]:
    """``(name, policy, environment it plays, its kind)`` of a learned member (its knob not applied)."""
    from agents.evaluation.evaluate import check_trained_on, played_env
    from agents.evaluation.policies import PolicySpec, load_agent
    from agents.risk.pretrained import is_pretrained_name
    from agents.training.learned_rule_policy import is_learned_rule
    from agents.training.selector_policy import is_selector
    from envs.interface import tuning_env_of

    path = task.member
    if is_pretrained_name(path):  # a shipped learner at a risk: load_agent resolves the name
        kind, spec = "learned-rule", PolicySpec(path, "learned-rule", path)
    else:
        kind = "selector" if is_selector(path) else "learned-rule" if is_learned_rule(path) else "agent"
        spec = PolicySpec(task.family, kind, path)
    name, policy = load_agent(spec)
    check_trained_on(policy, task.env, f"{task.family} ({path})")
    unwrapped = tuning_env_of(env)
    scoring = {"constraints": unwrapped.constraints, "weights": unwrapped.weights, **task.env_kwargs,
               "noise_std": unwrapped.options.noise_std}
    played = played_env(policy, task.env, {**dict(getattr(policy, "env_kwargs", None) or {}), **scoring})
    return name, policy, played, kind


def _identity(task: Member, kind: str) -> str:
    return f"{kind}|{task.member}|knob={task.knob!r}"


def _player(task: Member, env: Any) -> tuple[Any, Any, str]:
    """The played policy at the knob, the environment it plays, and its cache identity."""
    from agents.frontier.families import at_knob

    name, policy, played, kind = _loaded(task, env)
    return at_knob(name, policy, task.knob, played), played, _identity(task, kind)


def _identified(env: Any, seed: int, plant: Any) -> float:
    """The fixed mode's identification of ``plant`` (``env`` reset); returns the experiments' time in residence times."""
    from envs.interface import episode_of

    env.reset(seed=seed, options={"plant": plant})
    return episode_of(env).evidence.experiment_time / plant.residence_time


def _on_identification(env: Any, kind: str, name: str, experiment_time: float) -> Any:
    """A rule's or the oracle's result on the identification ``env`` holds."""
    from agents.evaluation.run import PolicyResult, oracle_result, rule_result
    from envs.interface import episode_of

    if episode_of(env).identification is None:
        return PolicyResult.failed(ValueError("the identification procedure identified no usable model"), experiment_time)
    if kind == "oracle":
        return oracle_result(env, False, experiment_time)[0]
    return rule_result(env, name, experiment_time)


@dataclass(frozen=True)
class Knobs:
    """The members of one family at every knob of a grid, one seed, one chunk of plants, scored on one reset per
    plant: a rule's design and score do not touch the episode; a learned member plays its own copy of the episode
    just reset (:func:`copy.deepcopy`), so that each member's table is the one its own :class:`Member` task writes."""

    members: tuple[Member, ...]

    @property
    def name(self) -> str:
        first = self.members[0]
        knobs = ", ".join(f"{member.knob!r}" for member in self.members)
        seed = f" seed {first.seed}" if first.seed else ""
        return (f"{first.stage} {first.family}@[{knobs}]{seed} plants {first.first}-{first.first + len(first.plants) - 1} "
                f"({first.regime})")


def batched(tasks: list[Member]) -> list[Member | Knobs]:
    """``tasks`` with each family's members of one regime, stage, seed and chunk gathered into one :class:`Knobs` (in
    the order of their first member), the oracle's as they are."""
    groups: dict[tuple[str, ...], list[Member]] = {}
    found: list[Member | list[Member]] = []
    for task in tasks:
        if task.kind == "oracle":
            found.append(task)
            continue
        key = (task.regime, task.stage, task.kind, task.family, task.member, task.seed, str(task.first))
        if key not in groups:
            groups[key] = []
            found.append(groups[key])
        groups[key].append(task)
    return [Knobs(tuple(item)) if isinstance(item, list) else item for item in found]


def _environment(task: Member) -> tuple[Any, str, str]:
    """The fixed mode's environment of ``task``'s regime, its cache name and its plant family."""
    import json

    from agents.environments import make_env
    from envs.interface import tuning_env_of

    env = make_env(task.env, {"experiments": "fixed", **task.env_kwargs})
    return env, f"{task.env} {json.dumps(task.env_kwargs, sort_keys=True, default=str)}", tuning_env_of(env).family


def _write(directory: Path, rows: list[list[str]]) -> None:
    from agents.files.writer import csv_text, write_text

    write_text(directory / TABLE, csv_text(rows))


def timed(directory: Path, started: tuple[float, float], episodes: int, members: int) -> None:
    """Add this session's CPU and wall seconds and its new episodes to ``directory/timing.json`` (the budget of
    :mod:`agents.protocol.budget`; a resumed task adds its sessions)."""
    import time

    from agents.files.reader import read_record
    from agents.files.writer import write_json

    path = directory / TIMING
    found = read_record(path, dict) or {"cpu_seconds": 0.0, "wall_seconds": 0.0, "episodes": 0, "members": members}
    write_json(path, {"cpu_seconds": found["cpu_seconds"] + _cpu() - started[0],
                      "wall_seconds": found["wall_seconds"] + time.perf_counter() - started[1],
                      "episodes": found["episodes"] + episodes, "members": members})


def _cpu() -> float:
    """CPU seconds of this process and its finished children (a learner's environments may run in subprocesses)."""
    import resource

    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def clock() -> tuple[float, float]:
    import time

    return _cpu(), time.perf_counter()


def _row(index: int, result: Any) -> list[str]:
    return [str(index), repr(float(result.cost)), str(bool(result.feasible))]


def score_member(task: Member) -> str:
    """Run ``task`` (module docstring): a batch of one (:func:`score_knobs`); returns its folder."""
    if task.kind not in KINDS:
        raise ValueError(f"unknown member kind {task.kind!r} (kinds: {', '.join(KINDS)})")
    return score_knobs(Knobs((task,)))


def _knob_scorers(todo: list[Member], env: Any) -> tuple[list[str], Callable[[int, Any], Any], Callable[[Member], Any], Any]:
    """``(identities, reset(seed, plant), score(member), the environment played or None)`` of a batch's members: a
    rule's or the oracle's on the identification of ``env``, a learned member's episode on its own copy of its
    environment just reset."""
    import copy

    from agents.evaluation.run import agent_played, selector_played
    from agents.frontier.families import at_knob
    from baselines.rules.family import member_name

    if todo[0].kind != "learned":  # a rule's or the oracle's result on the identification of ``env``
        state: dict[str, Any] = {}

        def identity(task: Member) -> str:
            return "oracle" if task.kind == "oracle" else member_name(task.member, task.knob)

        def reset(seed: int, plant: Any) -> None:
            state["time"] = _identified(env, seed, plant)

        return ([identity(task) for task in todo], reset,
                lambda task: _on_identification(env, task.kind, identity(task), state["time"]), None)
    name, policy, played, kind = _loaded(todo[0], env)
    state = {}

    def reset_played(seed: int, plant: Any) -> None:
        state["observation"], _ = played.reset(seed=seed, options={"plant": plant})
        state["plant"] = plant

    def score(task: Member) -> Any:
        own = copy.deepcopy(played)
        player = at_knob(name, policy, task.knob, own)
        observation = copy.deepcopy(state["observation"])
        if hasattr(player, "rule_of"):
            return selector_played(own, player, observation, state["plant"])
        return agent_played(own, player, observation)

    return [_identity(task, kind) for task in todo], reset_played, score, played


def score_knobs(batch: Knobs) -> str:
    """Run ``batch`` (:class:`Knobs`): per plant one reset, then each member not yet done; returns the first
    member's folder."""
    from agents.evaluation.cache import Cache
    from agents.evaluation.run import plant_key
    from envs.systems.plants import as_plant

    todo = [task for task in batch.members if not (Path(task.directory) / TABLE).exists()]
    if not todo:
        return batch.members[0].directory
    first, started, episodes = todo[0], clock(), 0
    env, environment, family = _environment(first)
    for task in todo:
        Path(task.directory).mkdir(parents=True, exist_ok=True)
    caches = [Cache(Path(task.directory) / "cache.jsonl") for task in todo]
    identities, reset, score, played = _knob_scorers(todo, env)
    tables = [[["index", "cost", "feasible"]] for _ in todo]
    for offset, data in enumerate(first.plants):
        index, plant = first.first + offset, as_plant(dict(data))
        seed = first.episode_seed + index
        key = plant_key(environment, family, seed, index, dict(data))
        results = [cache.get(key, identity) for cache, identity in zip(caches, identities)]
        if any(result is None for result in results):
            reset(seed, plant)
        for k, (task, cache, identity) in enumerate(zip(todo, caches, identities)):
            if results[k] is None:
                results[k] = score(task)
                cache.put(key, identity, results[k])
                episodes += 1
            tables[k].append(_row(index, results[k]))
    env.close()
    if played is not None:
        played.close()
    timed(Path(first.directory), started, episodes, len(todo))
    for task, rows in zip(todo, tables):
        _write(Path(task.directory), rows)
    return batch.members[0].directory
