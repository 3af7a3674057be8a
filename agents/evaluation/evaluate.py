"""Policies against every rule and the per-plant oracle on held-out plants (``deadtime evaluate``,
whose command line is :mod:`agents.commands.evaluate`).

Plants: the fixed held-out test set ``envs.systems.plant_sets.plant_set(family, "test", n)`` (or the user's
own, ``--plants FILE``: a JSON list of plants, labelled ``user-0``, ``user-1``, ...) and, unless
``--no-benchmark``, the papers' benchmark batch of the environment's structure
(``envs.systems.plant_sets.benchmark_set``).  Each plant is played in one episode, reset with seed
``--seed + i`` for test plant ``i`` and ``--seed + 1000000 + j`` for benchmark plant ``j`` (so that
no seed depends on ``--n``): the noise of its identification is the same for every policy.
How each policy is scored, and what a rule's failure costs: :mod:`agents.evaluation.run`; the
policies: :mod:`agents.evaluation.policies`; the statistics (regret, gap closure, paired
bootstrap seeded with ``--seed``): :mod:`agents.evaluation.stats`.

The gap closure's reference, the *paper rule* (``best_rule`` in ``results.json``), is the rule of lowest mean cost over all plants among the rules of the
environment's own structure (the ``mu`` rules in ``PID-v0``, the FPPI ``T_r`` rules in ``FPPI-v0``,
the MSP ``T_r`` rules in ``MSP-v0``): the oracle is the per-plant optimum of that structure's one
parameter, so only those rules are bounded by it.  They and the oracle are always computed (regret
and gap closure need them); the table shows the listed policies plus the oracle and the paper rule.

Writes into ``--out``: ``results.md``, ``results.csv``, ``results.json`` (also printed by
``--json``), ``per_plant.csv``, ``costs.png`` and, for a few representative plants (the best
rule's median- and largest-regret plants, and each agent's median-regret plant),
``responses_<plant>.png`` and ``nyquist_<plant>.png``.  Per-plant results are appended to
``cache.jsonl``, so an interrupted run resumes where it stopped; the key holds a hash of the source
of ``envs`` and ``baselines``, so results of other code are recomputed, not reused, and each line a
checksum, so a line edited or damaged is recomputed too (said in one line; :mod:`agents.evaluation.cache`).
``--workers N`` scores the rules and oracles in ``N`` processes (the oracle's search dominates; its
time per plant is in docs/performance.md); results do not depend on it.

From Python, :func:`evaluate` (also ``agents.evaluate``) takes the same options as keywords, and
policies given in Python beside the strings: callables ``observation -> action`` and objects with
stable-baselines3's ``predict``.  Without ``out`` it writes nothing and returns the table.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from numbers import Integral
from pathlib import Path
from typing import Any

from agents.environments import make_env
from agents.limits import MAX_RESAMPLES, MAX_TEST_PLANTS, MAX_WORKERS, require_at_most
from envs.interface import tuning_env_of
from envs.structures import STRUCTURES

__all__ = ["check_trained_on", "env_regime", "evaluate", "first_episode", "identity", "played_env", "score_plants"]


# --------------------------------------------------------------------------- setup
def _as_list(plants: Any, prefix: str) -> list[tuple[str, Any]]:
    if isinstance(plants, dict):
        return list(plants.items())
    return [(f"{prefix}-{i}", plant) for i, plant in enumerate(plants)]


def _plants(family: str, structure: str, n: int, benchmark: bool, given: list | None = None) -> list[tuple[str, str, Any]]:
    """``(subset, label, plant)`` of the test set (the plants ``given``, labelled ``user-<i>``, else
    ``n`` of the family's), then the benchmark batch."""
    from envs.systems.plant_sets import benchmark_set, plant_set

    if given is None:
        plants = [("test", label, plant) for label, plant in _as_list(plant_set(family, "test", n), f"test-{family}")]
    else:
        plants = [("test", f"user-{i}", plant) for i, plant in enumerate(given)]
    if benchmark:
        plants += [("benchmark", label, plant) for label, plant in _as_list(benchmark_set(structure), "benchmark")]
    return plants


def _given_plants(given: Any, structure: str) -> list[Any]:
    """The user's plants (:func:`envs.systems.plants.as_plant` of each), all of the environment's kind."""
    from envs.systems.plants import as_plant

    if not isinstance(given, list) or not given:
        raise ValueError(f"--plants must be a non-empty JSON list of plants, got {type(given).__name__}")
    if len(given) > MAX_TEST_PLANTS:
        raise ValueError(f"--plants must hold at most {MAX_TEST_PLANTS} plants (the documented limit, agents/limits.py), "
                         f"got {len(given)}")
    plants = []
    for i, value in enumerate(given):
        try:
            plants.append(as_plant(value, f"--plants[{i}]"))
        except ValueError as error:
            raise ValueError(f"--plants[{i}]: {error}" if not str(error).startswith("--plants[") else str(error)) from None
    integrating = STRUCTURES[structure].integrating
    for i, plant in enumerate(plants):
        if plant.integrating != integrating:
            kind = "integrating" if integrating else "self-regulating"
            raise ValueError(f"--plants[{i}] must be a {kind} plant for this environment")
    return plants


def _agents(specs: list, python: dict[str, Any], env_id: str, scoring: dict[str, Any],
            taken: set[str]) -> tuple[dict[str, tuple[Any, Any, str | None]], dict[str, str]]:  # fmt: skip
    """Each agent, learned rule, procedure and Python policy with the environment it plays and its cache
    identity (None for a Python policy: not cached); and the role of each in the tables.

    A policy's environment takes the policy's own keyword arguments (``experiments``, budget: its
    interface) but the evaluation's scoring (``scoring``: constraints, weights, noise), so that every
    policy is scored the same way.
    """
    from agents.evaluation.policies import ROLES, load_agent

    agents: dict[str, tuple[Any, Any, str | None]] = {}
    roles: dict[str, str] = {}
    for spec in specs:
        name, policy = load_agent(spec)
        if name in taken or name in agents:
            raise ValueError(f"policy name {name!r} of agent {spec.path!r} is taken; name it with NAME=PATH")
        check_trained_on(policy, env_id, f"agent {spec.path!r}")
        kwargs = {**dict(getattr(policy, "env_kwargs", None) or {}), **scoring}
        if spec.kind == "procedure" and spec.name == "plan-best":
            from agents.evaluation.plan_search import best_plan

            policy, _ = best_plan(env_id, kwargs)
        agents[name] = (policy, played_env(policy, env_id, kwargs), identity(spec, policy, kwargs))
        roles[name] = ROLES[spec.kind]
    for name, policy in python.items():
        if name in taken or name in agents:
            raise ValueError(f"policy name {name!r} is taken (a rule, an oracle or another policy); give it another name")
        check_trained_on(policy, env_id, f"policy {name!r}")
        kwargs = {**dict(getattr(policy, "env_kwargs", None) or {}), **scoring}
        agents[name] = (policy, played_env(policy, env_id, kwargs), None)
        roles[name] = ROLES["agent"]
    return agents, roles


def check_trained_on(policy: Any, env_id: str, what: str) -> None:
    """Refuse a policy that says it was trained on another environment (its ``env_id``)."""
    trained_on = getattr(policy, "env_id", None)
    if isinstance(trained_on, str) and trained_on != env_id:
        raise ValueError(f"{what} was trained on {trained_on}, not {env_id}")


def identity(spec: Any, policy: Any, kwargs: dict[str, Any]) -> str:
    """The cache identity of a loaded policy: its file (and modification time) or procedure, and its regime."""
    import os

    path = str(getattr(policy, "path", spec.path))
    stamp = os.path.getmtime(path) if os.path.exists(path) else 0.0
    source = f"procedure:{policy.name}" if spec.kind == "procedure" else os.path.abspath(path)
    return f"agent|{source}|{stamp}|{json.dumps(kwargs, sort_keys=True, default=str)}"


def played_env(policy: Any, env_id: str, kwargs: dict[str, Any]) -> Any:
    """The environment a policy plays, bound to the policy if it reads the observation by feature names."""
    env = make_env(env_id, kwargs)
    if hasattr(policy, "bind"):  # a procedure that reads the observation by its feature names
        base = tuning_env_of(env)
        policy.bind(base.feature_names, base.experiment_names)
    return env


def env_regime(env_kwargs: Any) -> dict[str, Any]:
    """The ``--env-kwargs`` of an evaluation, checked: a mapping of environment arguments without
    ``experiments`` (each policy plays its own mode); the environment checks the values."""
    if env_kwargs is None:
        return {}
    if not isinstance(env_kwargs, dict):
        raise ValueError(f"--env-kwargs must be a JSON object of environment arguments, got {type(env_kwargs).__name__}")
    if "experiments" in env_kwargs:
        raise ValueError("--env-kwargs: 'experiments' is not an evaluation's choice (each policy plays its own mode)")
    return dict(env_kwargs)


def first_episode(env: Any, plant: Any, seed: int) -> None:
    """Reset ``env`` on the first plant with its seed, before anything is written: an argument of the
    regime that only an episode reads, and cannot take, is refused with no output folder left."""
    try:
        env.reset(seed=seed, options={"plant": plant})
    except (TypeError, KeyError, AssertionError, OverflowError) as error:
        raise ValueError(f"--env-kwargs: refused by the environment: {error or error.__class__.__name__}") from None


def _check_sizes(n: Any, seed: Any, resamples: Any, workers: Any) -> None:
    """``n``, ``resamples`` and ``workers`` integers from 1 to their limits (:mod:`agents.limits`), ``seed`` >= 0."""
    for name, value, low, limit in (("--n", n, 1, MAX_TEST_PLANTS), ("--seed", seed, 0, None),
                                    ("--resamples", resamples, 1, MAX_RESAMPLES), ("--workers", workers, 1, MAX_WORKERS)):
        if not isinstance(value, Integral) or isinstance(value, bool) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
        if limit is not None:
            require_at_most(value, limit, name)


BENCHMARK_SEED_OFFSET = 1_000_000
"""Episode seed of benchmark plant ``j``: ``--seed + BENCHMARK_SEED_OFFSET + j``, whatever ``--n``."""


def _episode_seeds(plants: list[tuple[str, str, Any]], seed: int) -> list[int]:
    """``seed + i`` for test plant ``i``; ``seed + BENCHMARK_SEED_OFFSET + j`` for benchmark plant ``j``.

    Neither depends on ``--n`` (the ``i``-th test plant does not either), so runs with different
    ``n`` agree on their common plants and share the cache.
    """
    out, benchmark = [], 0
    for i, (subset, _, _) in enumerate(plants):
        if subset == "test":
            out.append(seed + i)
        else:
            out.append(seed + BENCHMARK_SEED_OFFSET + benchmark)
            benchmark += 1
    return out


# --------------------------------------------------------------------------- the run
def evaluate(
    env_id: str,
    policies: str | Sequence[Any] | Mapping[str, Any],
    n: int = 50,
    seed: int = 0,
    out: Path | str | None = None,
    *,
    family: str | None = None,
    benchmark: bool = True,
    resamples: int = 2000,
    plots: bool = True,
    workers: int = 1,
    plants: list | None = None,
    env_kwargs: dict[str, Any] | None = None,
    warn: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Evaluate ``policies`` on ``env_id``'s held-out plants; with ``out``, write the outputs there.

    Returns the ``results.json`` object (see the module docstring): ``result["policies"]`` holds one
    row per policy (name, role, mean and median cost, violation and failure rates, regret, gap
    closure, ``ci95`` intervals), sorted by mean cost.  Without ``out`` nothing is written (no
    tables, plots or cache)::

        from agents.evaluation.evaluate import evaluate

        result = evaluate("DeadTime/PID-v3", ["simc-pi", "oracle", {"mine": lambda observation: [0.0]}],
                          n=5, benchmark=False)
        for row in result["policies"]:
            print(row["name"], row["role"], row["mean_cost"], row["regret"])

    Parameters
    ----------
    env_id : str
        A registered environment id, e.g. ``DeadTime/PID-v3``.
    policies : str, list or mapping
        ``--policies``' comma-separated string, or a list whose items are such strings, Python
        policies (a callable ``observation -> action``, or an object with stable-baselines3's
        ``predict``, such as a model just trained) and mappings of names to Python policies
        (:func:`agents.evaluation.policies.split_policies`).  A Python policy plays like an agent,
        in the environment's own mode unless it has ``env_kwargs`` (e.g.
        ``CallablePolicy(name, function, {"experiments": "agent"})``); its results are not cached.
    n, seed : int
        ``--n`` random test plants (from 1) and the seed (>= 0) of the episodes and the bootstrap.
    out : Path or str, optional
        The output directory (``--out``); None writes nothing.
    plants : list, optional
        Plants in any form :func:`envs.systems.plants.as_plant` takes; they replace the ``n`` random
        test plants.
    env_kwargs : dict, optional
        Environment arguments (noise, weights, amplitude limit, ...) that set the regime: the rules and
        oracles play the environment made with them, and every agent is scored in them (over its own
        ``env_kwargs``); they are part of the cache key and of ``results.json``.
    warn : callable, optional
        Takes the one line that says which lines of ``cache.jsonl`` were dropped and recomputed
        (default: printed on stderr).

    The other arguments are the options of ``deadtime evaluate`` of the same names.

    Raises
    ------
    ValueError
        For an unknown environment, policy or rule, ``n``, ``resamples`` or ``workers`` not an integer
        from 1 to its limit (:mod:`agents.limits`), ``seed`` not an integer >= 0, or an agent that cannot
        be loaded; all before ``out`` is created.
    """
    from agents.evaluation.policies import split_policies

    _check_sizes(n, seed, resamples, workers)
    if isinstance(out, str):
        if not out.strip():  # the empty string would write into the working directory
            raise ValueError("out must name a directory, got the empty string")
        out = Path(out)
    text, python = split_policies(policies)
    return _evaluate(env_id, text, python, int(n), seed, out, family=family, benchmark=benchmark, resamples=resamples,
                     plots=plots, workers=workers, plants=plants, env_kwargs=env_kwargs, warn=warn or _print_warning)


def _evaluate(env_id: str, text: str | None, python: dict[str, Any], n: int, seed: int, out: Path | None, *,
              family: str | None, benchmark: bool, resamples: int, plots: bool, workers: int, plants: list | None,
              env_kwargs: dict[str, Any] | None, warn: Callable[[str], None]) -> dict[str, Any]:  # fmt: skip
    """:func:`evaluate` of checked sizes: the policy strings ``text`` and the Python policies ``python``."""
    import numpy as np

    from agents.evaluation.policies import PLAYED, own_rules, parse_policies

    started = time.perf_counter()
    regime = env_regime(env_kwargs)
    env_kwargs = {**regime, **({} if family is None else {"family": family})}
    env = make_env(env_id, {"experiments": "fixed", **env_kwargs})
    unwrapped = tuning_env_of(env)
    structure = unwrapped.structure
    family = family or getattr(unwrapped, "family", None) or STRUCTURES[structure].family
    specs = [] if text is None else parse_policies(text, structure)
    listed_rules = [s.name for s in specs if s.kind == "rule"]
    own = own_rules(structure)
    rules = listed_rules + [name for name in own if name not in listed_rules]
    scoring = {"constraints": unwrapped.constraints, "weights": unwrapped.weights, **env_kwargs,
               "noise_std": unwrapped.options.noise_std}
    agents, agent_roles = _agents([s for s in specs if s.kind in PLAYED], python, env_id, scoring,
                                  {*rules, "oracle", "oracle-full"})
    given = None if plants is None else _given_plants(plants, structure)
    count = f"{n} test plants" if given is None else f"{len(given)} given plants"
    plants = _plants(family, structure, n, benchmark, given)
    first_episode(env, plants[0][2], _episode_seeds(plants, seed)[0])
    into = "" if out is None else f" into {out}"
    print(f"evaluate {env_id}: {count}{' and the benchmark batch' if benchmark else ''}{into}", file=sys.stderr, flush=True)

    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    full = any(s.kind == "oracle-full" for s in specs)
    cache = None if out is None else out / "cache.jsonl"
    results, per_plant, mismatch = score_plants(env, env_id, env_kwargs, regime, plants, seed, rules, agents, cache, full, workers,
                                                 warn)
    means = {name: float(np.mean([found[name].cost for found in results])) for name in own}
    best_rule = min(own, key=lambda name: (means[name], name))
    shown = [s.name for s in specs if s.kind not in PLAYED] + list(agents)
    shown += [name for name in ("oracle", best_rule) if name not in shown]
    roles = _roles(shown, agent_roles, best_rule, listed_rules)
    subsets = _subset_statistics(plants, results, shown, best_rule, resamples, seed)
    elapsed = time.perf_counter() - started
    extra = {
        **({"chosen_plan": agents["plan-best"][0].name} if "plan-best" in agents else {}),
        "family": family,
        "structure": structure,
        "plants": len(plants),
        "benchmark_plants": sum(1 for p in plants if p[0] == "benchmark"),
        "best_rule": best_rule,
        "own_structure_rules": own,
        "oracle_rescore_max_difference": mismatch,
        "resamples": resamples,
        "wall_time_s": round(elapsed, 2),
        **({"env_kwargs": regime} if regime else {}),
        **_choices(results, list(agents)),
    }
    from agents.evaluation.report import results_json, write_tables

    n = n if given is None else len(given)  # the test plants evaluated: those given, where --plants gives them
    if out is None:
        return results_json(env_id, n, seed, subsets, roles, extra)
    notes = _notes(best_rule, own) + _failure_notes(results, plants) + _choice_notes(extra)
    result = write_tables(out, env_id, n, seed, subsets, roles, extra, per_plant, notes)
    if plots:
        _plots(out, env_id, plants, results, shown, roles, best_rule, list(agents), unwrapped.constraints)
    return result


def score_plants(
    env: Any,
    env_id: str,
    env_kwargs: dict[str, Any],
    regime: dict[str, Any],
    plants: list,
    seed: int,
    rules: list[str],
    agents: dict,
    cache_path: Path | None,
    full: bool,
    workers: int,
    warn: Callable[[str], None],
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], float]:
    """Every policy on every plant (with a progress bar): results, ``per_plant.csv`` rows, and the
    largest difference between the oracle's own cost and the environment's for its optimum.
    ``regime``, the evaluation's ``--env-kwargs``, is part of each plant's cache key; the cache is
    ``cache_path``, or kept in memory only if it is None.

    With ``workers > 1`` the rules and oracles run in that many processes first (into the cache);
    the agents then run in this process.  ``warn`` gets the cache's :meth:`~agents.evaluation.cache.Cache.note`.
    """
    from tqdm import tqdm

    from agents.evaluation.run import Cache, evaluate_plant, fill_cache_in_parallel, plant_key

    cache = Cache(cache_path)
    seeds = _episode_seeds(plants, seed)
    family = tuning_env_of(env).family
    environment = env_id if not regime else f"{env_id} {json.dumps(regime, sort_keys=True, default=str)}"
    keys = [
        plant_key(environment, family, seeds[i], i if subset == "test" else label, plant.to_dict())
        for i, (subset, label, plant) in enumerate(plants)
    ]
    mismatch = 0.0
    if workers > 1:
        with tqdm(total=len(plants), desc=f"evaluate {env_id} ({workers} workers)", unit="plant", file=sys.stderr) as bar:
            episodes = [(plant, seeds[i], keys[i]) for i, (_, _, plant) in enumerate(plants)]
            mismatch = fill_cache_in_parallel(
                env_id, {"experiments": "fixed", **env_kwargs}, episodes, rules, cache, workers,
                full_oracle=full, progress=bar.update,
            )  # fmt: skip
    results: list[dict[str, Any]] = []
    rows: list[dict[str, Any]] = []
    for index, (subset, label, plant) in enumerate(tqdm(plants, desc=f"evaluate {env_id}", unit="plant", file=sys.stderr)):
        key = keys[index]
        found, off = evaluate_plant(env, plant, seeds[index], rules, agents, cache, key, full_oracle=full)
        mismatch = max(mismatch, off)
        results.append(found)
        common = {"index": index, "subset": subset, "plant": label, "seed": seeds[index]}
        rows += [
            {**common, "policy": name, **r.to_dict(), "controller": json.dumps(r.controller), "error": r.error or ""}
            for name, r in found.items()
        ]
    if cache.note() is not None:
        warn(cache.note())
    return results, rows, mismatch


def _choices(results: list[dict[str, Any]], names: list[str]) -> dict[str, Any]:
    """``{"choices": {selector: {candidate: share of plants}}}`` for the selectors among ``names`` (else nothing)."""
    from collections import Counter

    choices = {}
    for name in names:
        picked = Counter(found[name].choice for found in results)
        if None not in picked:
            choices[name] = {candidate: count / len(results) for candidate, count in picked.most_common()}
    return {"choices": choices} if choices else {}


def _choice_notes(extra: dict[str, Any]) -> list[str]:
    return [f"{name} gave the plants to " + ", ".join(f"`{c}` {share:.1%}" for c, share in shares.items())
            for name, shares in extra.get("choices", {}).items()]


def _print_warning(line: str) -> None:
    print(f"deadtime evaluate: {line}", file=sys.stderr, flush=True)


def _roles(shown: list[str], agents: dict[str, str], best_rule: str, listed_rules: list[str]) -> dict[str, str]:
    """The role of each row of the tables (see :mod:`agents.evaluation.report`); ``agents`` holds the
    role of each agent and learned rule."""
    roles = {name: "rule" for name in shown}
    roles.update(agents)
    roles.update({name: name for name in ("oracle", "oracle-full") if name in shown})
    roles[best_rule] = "paper rule" if best_rule in listed_rules else "paper rule (reference)"
    return roles


def _subset_statistics(
    plants: list, results: list[dict[str, Any]], shown: list[str], best_rule: str, resamples: int, seed: int
) -> dict[str, list]:
    """:func:`agents.evaluation.stats.summarize` over all plants, the test set and the benchmark batch."""
    import numpy as np

    from agents.evaluation.stats import summarize

    def column(name: str, field: str, rows: np.ndarray) -> np.ndarray:
        return np.array([getattr(found[name], field) for found in results], dtype=float)[rows]

    subsets: dict[str, list] = {}
    for subset in ("all", "test", "benchmark"):
        rows = np.array([subset == "all" or p[0] == subset for p in plants])
        if not rows.any():
            continue
        subsets[subset] = summarize(
            {name: column(name, "cost", rows) for name in shown},
            {name: 1.0 - column(name, "feasible", rows) for name in shown},
            {name: column(name, "failure", rows) for name in shown},
            {name: column(name, "experiment_time", rows) for name in shown},
            column("oracle", "cost", rows),
            column(best_rule, "cost", rows),
            resamples=resamples,
            seed=seed,
        )
    return subsets


def _notes(best_rule: str, own: list[str]) -> list[str]:
    from agents.evaluation.run import FAILURE_COST

    best = (
        f"Paper rule: {best_rule}, the lowest mean cost among the papers' rules of the environment's own structure "
        f"({', '.join(own)}); the oracle is the per-plant optimum of that structure's parameter, so only these "
        "rules are bounded by it. Gap closure = (mean cost of the paper rule - mean cost)/(mean cost of the paper rule "
        "- mean cost of the oracle)."
    )
    regret = (
        "Regret = mean over plants of (cost - oracle cost), the oracle searched on the same identified data and "
        "re-scored by the environment (experiment cost included)."
    )
    failure = (
        "A rule that raises on a plant (it needs a quantity that was not identified, e.g. msp-tr-tn a positive T_n, "
        "or its formula gives an invalid controller) is a failure: it counts as a violation with the cost of an "
        f"unstable loop ({FAILURE_COST:g}); `failures` is their share."
    )
    intervals = (
        "Intervals: 95 % percentile bootstrap over plants, paired (every policy on the same resampled plants), the "
        "best rule fixed (chosen on all plants, also in the subsets' tables). Experiment time in units of the true "
        "plant's T_ar."
    )
    return [best, regret, failure, intervals]


def _failure_notes(results: list, plants: list) -> list[str]:
    """One line per policy that failed somewhere: how often, and the first plant and message."""
    failed: dict[str, list[tuple[str, str]]] = {}
    for (_, label, _), found in zip(plants, results):
        for name, result in found.items():
            if result.failure:
                failed.setdefault(name, []).append((label, result.error or ""))
    return [
        f"Failures of {name}: {len(cases)} of {len(plants)} plants; first on {cases[0][0]}: {cases[0][1]}"
        for name, cases in sorted(failed.items())
    ]


def _curve_label(name: str, result: Any) -> str:
    """``name: cost C, parameter P`` for a responses legend."""
    parameter = "" if result.parameter is None else f", parameter {result.parameter:.3g}"
    return f"{name}: cost {result.cost:.3g}{parameter}"


def _plots(out: Path, env_id: str, plants: list, results: list, shown: list[str], roles: dict[str, str],
           best_rule: str, agents: list[str], constraints: Any) -> None:  # fmt: skip
    import numpy as np

    from agents.evaluation.plots import cost_distribution_plot, nyquist_plot, responses_plot
    from envs.systems.controllers import controller_from_dict
    from envs.analysis.scoring import FEASIBLE_CAP

    for stale in [*out.glob("responses_*.png"), *out.glob("nyquist_*.png")]:
        stale.unlink()  # from an earlier run with other representative plants
    costs = {name: np.array([found[name].cost for found in results]) for name in shown}
    cost_distribution_plot(costs, roles, out / "costs.png", f"{env_id}: cost per plant ({len(plants)} plants)", FEASIBLE_CAP)
    oracle = costs["oracle"]
    chosen: list[int] = []
    for name in [best_rule, *agents]:
        regret = costs[name] - oracle
        order = np.argsort(regret, kind="stable")
        picks = [int(order[len(order) // 2])] + ([int(order[-1])] if name == best_rule else [])
        chosen += [i for i in picks if i not in chosen]
    drawn = ["oracle", best_rule, *agents] + (["oracle-full"] if "oracle-full" in shown else [])
    for i in chosen[:4]:
        _, label, plant = plants[i]
        controllers = {
            name: controller_from_dict(results[i][name].controller)
            for name in drawn
            if results[i][name].controller is not None
        }
        title = f"{env_id}, plant {label}"
        slug = "".join(c if c.isalnum() or c in "-_" else "_" for c in label)
        labels = {name: _curve_label(name, results[i][name]) for name in controllers}
        responses_plot(plant, controllers, out / f"responses_{slug}.png", title, labels)
        nyquist_plot(plant, controllers, constraints.max_sensitivity, out / f"nyquist_{slug}.png", title)
