"""Scoring every policy on one plant, the way ``deadtime evaluate`` does, with a resumable cache.

One plant, one episode: the environment (``experiments="fixed"``) is reset once with the plant and
the seed ``seed + index``, which runs the fixed identification procedure with its noise; then

* a rule designs from :meth:`baselines.rules.registry.RuleInputs.from_identification` of that identification
  and is scored by the environment's own ``score_controller`` (its constraints, weights and
  experiment time), so every policy is scored by the same code;
* the oracle (:func:`baselines.oracle.oracle`) searches on the same identification with the
  environment's constraints and weights; its optimum is re-scored with ``score_controller`` so that
  its cost follows the environment's cost convention exactly (experiment cost included) -- the
  experiment cost is the same constant for every parameter, so the optimum does not move;
* the full-information oracle designs from the exact model and is charged no experiment;
* an agent plays its own environment (made with the agent's ``env_kwargs`` if it has them) reset
  with the same plant and seed, one step in fixed mode, until termination in agent mode; its cost
  is the final step's ``info["cost"]``.

A rule that raises ``ValueError`` on a plant (a rule may need a quantity the procedure did not
identify, e.g. ``msp-tr-tn`` a positive ``T_n``; a formula may give an invalid controller) is a *failure*: it
counts as a constraint violation with the cost of an unstable loop,
``FEASIBLE_CAP + 1 + UNSTABLE_GRADE`` (:mod:`envs.analysis.scoring`), and is counted separately.  The same
holds for the oracles.

Experiment time is in units of the true plant's ``T_ar``.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluation.cache import Cache
from agents.evaluation.result import FAILURE_COST, PolicyResult
from agents.interruptions import GRACE_S, ignore_interrupts_in_worker
from envs.interface import episode_of

__all__ = ["FAILURE_COST", "Cache", "PolicyResult", "agent_action", "agent_result", "evaluate_plant", "oracle_result", "plant_key", "rule_result", "selector_result"]


CACHE_VERSION = 3
"""Bumped whenever a cached result would change meaning (2: dimensionless rule parameters; 3: lines
carry a checksum, :mod:`agents.evaluation.cache`)."""


_FINGERPRINT: list[str] = []


def code_fingerprint() -> str:
    """A hash of the source of ``envs`` and ``baselines``: cached results of other code are not reused."""
    if not _FINGERPRINT:
        import baselines
        import envs

        digest = hashlib.sha1()
        for package in (envs, baselines):
            root = Path(package.__file__).parent
            for path in sorted(root.rglob("*.py")):
                digest.update(str(path.relative_to(root)).encode())
                digest.update(path.read_bytes())
        _FINGERPRINT.append(digest.hexdigest())
    return _FINGERPRINT[0]


def plant_key(env_id: str, family: str, seed: int, position: int | str, plant_dict: dict[str, Any]) -> str:
    """The cache key of one episode: cache version, :func:`code_fingerprint`, environment, plant set,
    episode seed, position in the set (index or name) and the plant itself."""
    text = json.dumps([CACHE_VERSION, code_fingerprint(), env_id, family, seed, position, plant_dict], sort_keys=True)
    return hashlib.sha1(text.encode()).hexdigest()


def _finite(x: Any) -> float | None:
    return float(x) if x is not None and math.isfinite(float(x)) else None


def rule_result(env: Any, name: str, experiment_time: float) -> PolicyResult:
    from baselines.rules.registry import RuleInputs, get_rule

    rule = get_rule(name)
    try:
        episode = episode_of(env)
        inputs = RuleInputs.from_identification(episode.identification)
        controller = rule(inputs)
        parameter = rule.relative_parameter(inputs)
        score = episode.score_controller(controller)
    except ValueError as error:
        return PolicyResult.failed(error, experiment_time)
    return PolicyResult(float(score.cost), bool(score.feasible), False, experiment_time, controller.to_dict(), _finite(parameter))


def oracle_result(env: Any, full: bool, experiment_time: float) -> tuple[PolicyResult, float]:
    """The oracle's result and ``|its own cost - the environment's cost|`` of its optimum."""
    from baselines.oracle import exact_models, full_information_oracle, oracle
    from envs.structures import STRUCTURES, design
    from envs.analysis.scoring import score

    episode = episode_of(env)
    plant, structure = episode.plant, episode.structure
    options = {"constraints": episode.constraints, "weights": episode.weights}
    identification = episode.identification
    try:
        if full:
            result = full_information_oracle(plant, structure, **options)
            models = exact_models(plant)
        else:
            result = oracle(plant, identification, structure, **options)
            models = identification
        controller = design(structure, STRUCTURES[structure].model_of(models), result.parameter)
        if full:
            checked = score(plant, controller, experiment_time=0.0, **options)
        else:
            checked = episode.score_controller(controller)
    except ValueError as error:
        return PolicyResult.failed(error, 0.0 if full else experiment_time), 0.0
    mismatch = abs(float(checked.cost) - float(result.cost))
    return (
        PolicyResult(
            float(checked.cost), bool(checked.feasible), False, 0.0 if full else experiment_time,
            controller.to_dict(), _finite(result.relative_parameter),
        ),
        mismatch,
    )  # fmt: skip


def agent_action(env: Any, policy: Any, observation: np.ndarray) -> Any:
    """The agent's deterministic action for ``env.step``: an index chosen among the environment's action
    masks (the agent mode's discrete action), else the ``Box`` action in the space's shape."""
    from agents.training.validation import action_masks

    masks = action_masks(env)
    if masks is not None:
        action, _ = policy.predict(observation, deterministic=True, action_masks=masks)
        return int(np.asarray(action).reshape(-1)[0])
    action, _ = policy.predict(observation, deterministic=True)
    return np.asarray(action, dtype=np.float32).reshape(env.action_space.shape)


def agent_result(env: Any, policy: Any, seed: int, plant: Any) -> PolicyResult:
    observation, _ = env.reset(seed=seed, options={"plant": plant})
    return agent_played(env, policy, observation)


def agent_played(env: Any, policy: Any, observation: Any) -> PolicyResult:
    """An agent's episode from ``observation`` of an ``env`` just reset, to its end."""
    for _ in range(10_000):
        observation, _, terminated, truncated, info = env.step(agent_action(env, policy, observation))
        if terminated or truncated:
            break
    else:
        raise ValueError("the agent's episode did not end within 10000 steps")
    return _step_result(info)


def selector_result(env: Any, policy: Any, seed: int, plant: Any) -> PolicyResult:
    """A selector's episode (:mod:`agents.training.selector_policy`): reset with the plant and seed, the
    candidate it chooses from the observation, then that candidate's design on this identification: a
    rule scored as :func:`rule_result` scores it, a learned design's action stepped as an agent's."""
    observation, _ = env.reset(seed=seed, options={"plant": plant})
    return selector_played(env, policy, observation, plant)


def selector_played(env: Any, policy: Any, observation: Any, plant: Any) -> PolicyResult:
    """A selector's episode from ``observation`` of an ``env`` just reset with ``plant`` (:func:`selector_result`)."""
    import dataclasses

    episode = episode_of(env)
    choice = policy.choose(observation)
    rule = policy.rule_of(choice)
    if rule is not None and episode.identification is not None:
        result = rule_result(env, rule, episode.evidence.experiment_time / plant.residence_time)
    else:  # a learned design, or no identification (the step ends the episode without a design)
        action = policy.action(choice, observation) if rule is None else np.zeros(env.action_space.shape)
        info = env.step(np.asarray(action, dtype=np.float32).reshape(env.action_space.shape))[4]
        result = _step_result(info)
    return dataclasses.replace(result, choice=choice)


def _step_result(info: dict[str, Any]) -> PolicyResult:
    return PolicyResult(
        float(info["cost"]), bool(info["feasible"]), info.get("identified") is False,
        float(info.get("experiment_time", math.nan)), info.get("controller"), _finite(info.get("parameter")),
    )  # fmt: skip


def evaluate_plant(
    env: Any,
    plant: Any,
    seed: int,
    rules: list[str],
    agents: dict[str, tuple[Any, Any, str]],
    cache: Cache,
    key: str,
    *,
    full_oracle: bool = False,
) -> tuple[dict[str, PolicyResult], float]:
    """Every policy's result on ``plant`` (see the module docstring), from ``cache`` where present.

    Parameters
    ----------
    env : gymnasium.Env
        The environment in ``experiments="fixed"`` mode (rules and oracles).
    plant : envs.systems.plants.Plant
    seed : int
        The episode seed (``--seed`` plus the plant's index).
    rules : list of str
        Rule names.
    agents : dict of str to (policy, env, str or None)
        Each agent with the environment it plays and its cache identity (path and modification
        time, so that a retrained agent is not served stale results); None for a policy given in
        Python, whose results are never cached (its code has no identity to key them on).
    cache : Cache
    key : str
        The episode's :func:`plant_key`.
    full_oracle : bool
        Also run the full-information oracle (``"oracle-full"``).

    Returns
    -------
    (dict of str to PolicyResult, float)
        Results by policy name (``"oracle"`` always), and how far the oracle's own cost was from the
        environment's for its optimum (0 when served from the cache).
    """
    wanted = ["oracle", *rules] + (["oracle-full"] if full_oracle else [])
    results = {name: cache.get(key, name) for name in wanted}
    mismatch = 0.0
    if any(result is None for result in results.values()):
        env.reset(seed=seed, options={"plant": plant})
        episode = episode_of(env)
        identified = episode.identification is not None  # (v3: None when the fixed procedure failed)
        experiment_time = episode.evidence.experiment_time / plant.residence_time
        for name in wanted:
            if results[name] is not None:
                continue
            if not identified:
                results[name] = PolicyResult.failed(ValueError("the identification procedure identified no usable model"), experiment_time)
            elif name in ("oracle", "oracle-full"):
                results[name], off = oracle_result(env, name == "oracle-full", experiment_time)
                mismatch = max(mismatch, off) if name == "oracle" else mismatch
            else:
                results[name] = rule_result(env, name, experiment_time)
            cache.put(key, name, results[name])
    for name, (policy, agent_env, identity) in agents.items():
        result = None if identity is None else cache.get(key, identity)
        if result is None:
            play = selector_result if hasattr(policy, "rule_of") else agent_result
            result = play(agent_env, policy, seed, plant)
            if identity is not None:
                cache.put(key, identity, result)
        results[name] = result
    return results, mismatch  # type: ignore[return-value]


# --------------------------------------------------------------------------- parallel rules and oracles
_WORKER_ENVS: dict[str, Any] = {}


def _worker_env(env_id: str, env_kwargs: dict[str, Any]) -> Any:
    """One environment per worker process and configuration, made on first use."""
    from agents.environments import make_env

    key = json.dumps([env_id, env_kwargs], sort_keys=True, default=str)
    if key not in _WORKER_ENVS:
        _WORKER_ENVS[key] = make_env(env_id, env_kwargs)
    return _WORKER_ENVS[key]


def _worker(
    env_id: str, env_kwargs: dict[str, Any], plant: Any, seed: int, rules: list[str], key: str, full_oracle: bool
) -> tuple[str, dict[str, PolicyResult], float]:
    env = _worker_env(env_id, env_kwargs)
    results, mismatch = evaluate_plant(env, plant, seed, rules, {}, Cache(None), key, full_oracle=full_oracle)
    return key, results, mismatch


def fill_cache_in_parallel(
    env_id: str,
    env_kwargs: dict[str, Any],
    episodes: list[tuple[Any, int, str]],
    rules: list[str],
    cache: Cache,
    workers: int,
    *,
    full_oracle: bool = False,
    progress: Any = None,
) -> float:
    """Score the rules and oracles of every ``(plant, seed, key)`` episode missing from ``cache`` in
    ``workers`` processes (``spawn``: no state is inherited), and store them in ``cache``.

    Agents are not run here (their models stay in the main process).  ``progress`` is called once
    per episode finished.  Returns the largest oracle re-scoring difference (see :func:`evaluate_plant`).
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    wanted = ["oracle", *rules] + (["oracle-full"] if full_oracle else [])
    missing = [(plant, seed, key) for plant, seed, key in episodes if any(cache.get(key, name) is None for name in wanted)]
    mismatch = 0.0
    if not missing:
        return mismatch
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=ignore_interrupts_in_worker)
    try:
        futures = [pool.submit(_worker, env_id, env_kwargs, plant, seed, rules, key, full_oracle) for plant, seed, key in missing]
        for future in as_completed(futures):
            key, results, off = future.result()
            mismatch = max(mismatch, off)
            for name, result in results.items():
                if cache.get(key, name) is None:
                    cache.put(key, name, result)
            if progress is not None:
                progress()
    except BaseException:
        _end_pool(pool)
        raise
    pool.shutdown()
    return mismatch


def _end_pool(pool: Any) -> None:
    """Stop a pool at once (Ctrl-C, SIGTERM, a failed episode): its queued episodes cancelled, its workers
    ended (their finished episodes are in the cache already).  The workers ignore SIGINT
    (:func:`agents.interruptions.ignore_interrupts_in_worker`), so that Ctrl-C in a terminal, sent to
    the whole process group, prints no traceback of theirs."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
    for process in processes:
        process.join(GRACE_S)
        if process.is_alive():
            process.kill()
