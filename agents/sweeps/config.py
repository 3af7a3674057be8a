"""The schema of a sweep file (``configs/sweeps/NAME.yaml``) for ``deadtime sweep``.

A sweep is a study: training configs x environment ids x seeds, then the evaluation of every
trained agent, and of the rules and the oracle once per environment, on the held-out plants::

    name: fixed-mode                  # default: the file's stem
    env_kwargs: {noise_std: 0.1}      # optional: the study's regime, given to every trial's
                                      # environment (over its config's) and to the evaluation
    trials:
      - label: sac                    # names the runs, a plain file name (default: the config file's stem)
        config: configs/sac.yaml      # a training config, as for `deadtime train`
        overrides: [total_timesteps=3000]
        envs: [DeadTime/PID-v0, DeadTime/FPPI-v0]
        seeds: {first: 0, count: 10}  # or a list: [0, 1, 2]
    evaluation:
      policies: [all-rules, oracle]   # besides the agents; any policy of `deadtime evaluate`
      n: 50                           # random test plants (plus the papers' benchmark batch)
      seed: 0                         # the evaluation's episode seeds, as `deadtime evaluate --seed`
    failure:
      max_failures: 1                 # retries of a failed trial before it is reported as failed

The rules of ``configs/`` hold: ``yaml.safe_load`` into frozen dataclasses (within the limits of
:mod:`agents.files.reader`), an unknown key is an error that names it, paths are relative to the
directory the command runs in.  At most :data:`agents.limits.MAX_SEEDS` seeds per group,
:data:`agents.limits.MAX_TEST_PLANTS` test plants and :data:`agents.limits.MAX_RESAMPLES` resamples.  Each training
config is resolved and validated here (:func:`agents.training.config.validate`), with its overrides and the
trial's seed, and ``evaluation.policies`` parsed for each environment as ``deadtime evaluate`` would,
so that a bad config or a misspelled policy fails the sweep before any trial starts.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from agents.limits import MAX_RESAMPLES, MAX_SEEDS, MAX_TEST_PLANTS, require_at_most
from agents.training.config import TrainConfig, load_config
from agents.files.names import plain_name
from agents.files.reader import load_yaml_file
from agents.training.schema import integer_field as _integer, mapping_field as _mapping

__all__ = ["Evaluation", "Failure", "SweepConfig", "Trial", "TrialGroup", "evaluation_directory", "load_sweep"]


def _env_short(env_id: str) -> str:
    return env_id.split("/")[-1]


@dataclass(frozen=True)
class Trial:
    """One training run of the sweep: ``(label, env_id, seed)``, and its resolved config."""

    label: str
    env_id: str
    seed: int
    config_path: str
    overrides: tuple[str, ...]
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        """``label-ENV-sSEED``, e.g. ``sac-PID-v0-s3``: the trial's name and run directory."""
        return f"{self.label}-{_env_short(self.env_id)}-s{self.seed}"

    def to_dict(self) -> dict[str, Any]:
        """Plain values (Ray Tune's trial config, JSON); :meth:`from_dict` reads them back."""
        return {**dataclasses.asdict(self), "overrides": list(self.overrides), "env_kwargs": dict(self.env_kwargs)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Trial:
        return cls(**{**data, "overrides": tuple(data["overrides"]), "env_kwargs": dict(data.get("env_kwargs", {}))})

    def train_config(self, run_dir: Path) -> TrainConfig:
        """The config ``deadtime train`` would resolve, with the seed and the run directory set, and
        the sweep's ``env_kwargs`` over the config's."""
        overrides = [*self.overrides, f"seed={self.seed}"]
        config = load_config(self.config_path, env_id=self.env_id, overrides=overrides)
        env_kwargs = {**config.env_kwargs, **self.env_kwargs}
        return dataclasses.replace(config, output_dir=str(run_dir), env_kwargs=env_kwargs)


@dataclass(frozen=True)
class TrialGroup:
    """A training config with its overrides, over environment ids and seeds."""

    label: str
    config: str
    overrides: tuple[str, ...]
    envs: tuple[str, ...]
    seeds: tuple[int, ...]

    def trials(self, env_kwargs: Mapping[str, Any] | None = None) -> list[Trial]:
        return [Trial(self.label, env, seed, self.config, self.overrides, dict(env_kwargs or {}))
                for env in self.envs for seed in self.seeds]


@dataclass(frozen=True)
class Evaluation:
    """How every agent, rule and the oracle are scored (as ``deadtime evaluate``)."""

    policies: tuple[str, ...] = ("all-rules", "oracle")
    n: int = 50
    seed: int = 0
    resamples: int = 2000


@dataclass(frozen=True)
class Failure:
    """``max_failures``: retries of a failed trial (Ray Tune's ``FailureConfig``)."""

    max_failures: int = 1


@dataclass(frozen=True)
class SweepConfig:
    """A whole sweep file, resolved (module docstring)."""

    name: str
    groups: tuple[TrialGroup, ...]
    evaluation: Evaluation = field(default_factory=Evaluation)
    failure: Failure = field(default_factory=Failure)
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)

    def trials(self) -> list[Trial]:
        return [trial for group in self.groups for trial in group.trials(self.env_kwargs)]

    def envs(self) -> list[str]:
        return sorted({env for group in self.groups for env in group.envs})


def evaluation_directory(out: Path, env_id: str, name: str) -> Path:
    """``DIR/eval/ENV/NAME``: where the evaluation of a trial (or of the ``baselines``) is written."""
    return out / "eval" / _env_short(env_id) / name


# ------------------------------------------------------------------------------------ reading
def _strings(value: Any, where: str) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not value or not all(isinstance(item, str) and item for item in value):
        raise ValueError(f"{where} must be a non-empty list of strings, got {value!r}")
    return tuple(value)


def _seeds(value: Any, where: str) -> tuple[int, ...]:
    if isinstance(value, Mapping):
        value = _mapping(value, where, ("first", "count"))
        if "count" not in value:
            raise ValueError(f"{where} needs 'count' (and optionally 'first')")
        first = _integer(value.get("first", 0), f"{where}.first", 0)
        count = _integer(value["count"], f"{where}.count", 1)
        require_at_most(count, MAX_SEEDS, f"{where}.count")
        return tuple(range(first, first + count))
    if not isinstance(value, list) or not value:
        raise ValueError(f"{where} must be a non-empty list of seeds or {{first, count}}, got {value!r}")
    require_at_most(len(value), MAX_SEEDS, f"the number of {where}")
    seeds = tuple(_integer(item, f"{where}[{i}]", 0) for i, item in enumerate(value))
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"{where} repeats a seed: {list(seeds)}")
    return seeds


def _group(data: Any, where: str) -> TrialGroup:
    data = _mapping(data, where, ("label", "config", "overrides", "envs", "seeds"))
    for key in ("config", "envs", "seeds"):
        if key not in data:
            raise ValueError(f"{where} needs {key!r}")
    config = data["config"]
    if not isinstance(config, str) or not Path(config).is_file():
        raise ValueError(f"{where}.config: no such file: {config!r}")
    label = plain_name(data.get("label", Path(config).stem), f"{where}.label")  # names the trials' run folders
    overrides = _strings(data["overrides"], f"{where}.overrides") if data.get("overrides") else ()
    return TrialGroup(label, str(Path(config).resolve()), overrides, _strings(data["envs"], f"{where}.envs"), _seeds(data["seeds"], f"{where}.seeds"))


def _evaluation(data: Any) -> Evaluation:
    data = _mapping(data, "evaluation", [f.name for f in dataclasses.fields(Evaluation)])
    policies = _strings(data["policies"], "evaluation.policies") if "policies" in data else Evaluation.policies
    return Evaluation(
        policies=policies,
        n=_at_most(_integer(data.get("n", Evaluation.n), "evaluation.n", 1), MAX_TEST_PLANTS, "evaluation.n"),
        seed=_integer(data.get("seed", Evaluation.seed), "evaluation.seed", 0),
        resamples=_at_most(_integer(data.get("resamples", Evaluation.resamples), "evaluation.resamples", 1),
                           MAX_RESAMPLES, "evaluation.resamples"),
    )


def _at_most(value: int, limit: int, where: str) -> int:
    require_at_most(value, limit, where)
    return value


def load_sweep(path: str | Path) -> SweepConfig:
    """Read and check a sweep file; every trial's training config is resolved (and so checked) here.

    Raises
    ------
    ValueError
        Naming the file, key or value that is wrong.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"--config {path}: no such file")
    data = load_yaml_file(path)
    data = _mapping(data if data is not None else {}, str(path), ("name", "env_kwargs", "trials", "evaluation", "failure"))
    name = data.get("name", path.stem)
    if not isinstance(name, str) or not name:
        raise ValueError(f"{path}: name must be a non-empty string, got {name!r}")
    if not isinstance(data.get("trials"), list) or not data["trials"]:
        raise ValueError(f"{path}: trials must be a non-empty list of {{config, envs, seeds}}")
    groups = tuple(_group(item, f"trials[{i}]") for i, item in enumerate(data["trials"]))
    failure_data = _mapping(data.get("failure", {}), "failure", ("max_failures",))
    failure = Failure(_integer(failure_data.get("max_failures", Failure.max_failures), "failure.max_failures", 0))
    env_kwargs = data.get("env_kwargs") or {}
    if not isinstance(env_kwargs, Mapping) or "experiments" in env_kwargs:
        raise ValueError(f"{path}: env_kwargs must be a mapping of environment arguments without 'experiments' "
                         f"(each trial's config sets its mode), got {env_kwargs!r}")
    sweep = SweepConfig(name, groups, _evaluation(data.get("evaluation", {})), failure, dict(env_kwargs))
    names = [trial.name for trial in sweep.trials()]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"{path}: two trials are named {repeated[0]!r} (give the groups distinct labels)")
    from agents.training.config import validate

    for trial in sweep.trials():
        try:
            validate(trial.train_config(Path("unused")))
        except ValueError as error:
            raise ValueError(f"{path}, trial {trial.name}: {error}") from None
    _check_policies(path, sweep)
    return sweep


def _check_policies(path: Path, sweep: SweepConfig) -> None:
    """``evaluation.policies`` as ``deadtime evaluate`` parses them for each environment's structure, and
    with what the summary needs (the oracle and a rule), so that a misspelled policy fails the sweep
    before any trial trains."""
    from agents.environments import make_env
    from agents.evaluation.policies import parse_policies
    from envs.interface import tuning_env_of

    policies = sweep.evaluation.policies
    for env_id in sweep.envs():
        env = make_env(env_id, {"experiments": "fixed", **sweep.env_kwargs})
        structure = tuning_env_of(env).structure
        env.close()
        try:
            specs = parse_policies(",".join(policies), structure)
        except ValueError as error:
            raise ValueError(f"{path}: evaluation.policies: {error}") from None
        if "oracle" not in policies:
            raise ValueError(f"{path}: evaluation.policies must include 'oracle' (the normalized score needs it), "
                             f"got {list(policies)}")
        if not any(spec.kind == "rule" for spec in specs):
            raise ValueError(f"{path}: evaluation.policies must include at least one rule of {env_id}, got {list(policies)}")
