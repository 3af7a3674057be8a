"""The training run of ``deadtime train`` (:mod:`agents.commands.train`): a stable-baselines3 agent from a config.

The resolved config (see :mod:`agents.training.config` for the precedence) is printed and saved as
``<run>/config.yaml`` with the command, git commit and package versions; ``<run>/run.json`` records
them again with the timings.  The run directory then holds ``tensorboard/`` (TensorBoard logs),
``evaluations.json`` (validation history), ``checkpoints/``, ``best_model.zip`` (lowest mean
validation cost), and at the end ``model.zip`` (the final agent); ``VecNormalize`` statistics, if
used, sit beside each model as ``<stem>.normalization.json``, and ``<stem>.manifest.json`` records
both (:mod:`agents.training.policies` loads them as data).

A config with a ``lagrangian`` key trains against a limit on the violation rate
(:mod:`agents.training.lagrangian`; docs/lagrangian.md) and writes the multiplier's record,
``lagrangian.json``, at the end.

A config with ``algorithm: learned-rule`` (``configs/learned_rule.yaml``) is fitted by
:mod:`agents.training.learned_rule` instead (the oracle on training plants, a regression, a safety
margin chosen on the validation plants), into the same kind of run directory; the command chooses.

``--resume`` continues an interrupted run from its newest intact checkpoint
(:mod:`agents.training.checkpoints`: model, replay buffer, normalization statistics, the environments, every
random state, the validation history and schedule) exactly as the uninterrupted run: same
parameters, same validation numbers.  A damaged newest checkpoint is skipped with one line naming
the file.  SIGINT or SIGTERM writes a checkpoint at the next rollout boundary and stops
(:mod:`agents.training.interrupts`).  With ``--resume`` the config may come from the run itself (``--out DIR``
without ``--config``); a config that differs from the saved one is refused, except for
``total_timesteps`` (which may be raised to extend a run), ``output_dir`` and ``progress_bar``.

Reproducibility: one seed (the config's ``seed``, or ``--seed N``, the same as the override ``seed=N``)
drives ``set_random_seed``, the algorithm and the environments (environment ``i`` gets ``seed + i``); torch runs single-threaded with deterministic algorithms.  The
same config and seed give the same agent, interrupted and resumed or not.

The config is checked (:func:`agents.training.config.validate`) and the environments and the model are built
before anything is written, so a refused config leaves no run directory behind.

torch and stable-baselines3 are imported inside the functions.
"""

from __future__ import annotations

import dataclasses
import functools
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from agents.environments import make_env
from agents.runtime import git_commit, versions
from agents.training.config import TrainConfig, algorithm_class, load_config, validate
from agents.training.schema import refused_as

if TYPE_CHECKING:
    from agents.training.checkpoints import Checkpoint

__all__ = ["TrainResult", "checkpoint_steps", "run_directory", "train", "with_seed"]

# Keys that may differ between a run's saved config and the one given on --resume.
_RESUMABLE_CHANGES = {"total_timesteps", "output_dir", "progress_bar"}
_ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU", "gelu": "GELU", "silu": "SiLU"}
_OPTIMIZERS = {"adam": "Adam", "adamw": "AdamW", "rmsprop": "RMSprop", "sgd": "SGD"}


def with_seed(overrides: Sequence[str], seed: int | None) -> list[str]:
    """``overrides`` with ``seed=SEED`` of ``--seed`` appended (none if ``seed`` is None).

    Raises
    ------
    ValueError
        If an override sets another seed (``--seed 3 seed=4``), naming both.
    """
    if seed is None:
        return list(overrides)
    from agents.training.config import parse_override

    for text in overrides:
        path, value = parse_override(text)
        if path == ["seed"] and (type(value) is not int or value != seed):
            raise ValueError(f"--seed {seed} and the override {text.strip()!r} disagree; give the seed once")
    return [*overrides, f"seed={seed}"]


@dataclass(frozen=True)
class TrainResult:
    """What a finished run produced."""

    run_dir: Path
    num_timesteps: int
    session_steps: int
    train_seconds: float
    steps_per_second: float
    best_cost: float
    final_cost: float
    status: str = "finished"
    stopped_by: int | None = None


def run_directory(config: TrainConfig) -> Path:
    """The run directory of a config."""
    return Path(config.output_dir or Path("runs") / config.run_name)


# ----------------------------------------------------------------------------------- environments
def _monitored_env(env_id: str, env_kwargs: dict[str, Any]) -> Any:
    """``Monitor``-wrapped, inside the :class:`agents.training.checkpoints.SnapshotWrapper` that checkpoints it whole.

    In a ``subproc`` worker, SIGINT is ignored: Ctrl-C reaches the whole process group, and the
    training process, not its workers, decides when to stop (:mod:`agents.training.interrupts`).
    """
    import multiprocessing
    import signal as signals

    from stable_baselines3.common.monitor import Monitor

    from agents.training.checkpoints import SnapshotWrapper

    if multiprocessing.parent_process() is not None:
        signals.signal(signals.SIGINT, signals.SIG_IGN)
    return SnapshotWrapper(Monitor(make_env(env_id, env_kwargs)))


def make_vec_env(config: TrainConfig) -> Any:
    """The training environments (``Monitor``-wrapped, ``dummy`` or ``subproc``; or the ``native`` vector
    environment, :mod:`agents.training.native_vec_env`), not yet seeded."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    if config.vec_env == "native":
        from agents.training.native_vec_env import make_native_vec_env

        return make_native_vec_env(config.env_id, config.n_envs, dict(config.env_kwargs))
    factories = [functools.partial(_monitored_env, config.env_id, dict(config.env_kwargs)) for _ in range(config.n_envs)]
    if config.vec_env == "subproc" and config.n_envs > 1:
        return SubprocVecEnv(factories)
    return DummyVecEnv(factories)


# ----------------------------------------------------------------------------------- model
def _policy_kwargs(config: TrainConfig) -> dict[str, Any]:
    import torch

    kwargs = dict(config.policy_kwargs)
    for key, names, module in (("activation_fn", _ACTIVATIONS, torch.nn), ("optimizer_class", _OPTIMIZERS, torch.optim)):
        if key in kwargs:
            if kwargs[key] not in names:
                raise ValueError(f"policy_kwargs.{key} must be one of {', '.join(names)}, got {kwargs[key]!r}")
            kwargs[key] = getattr(module, names[kwargs[key]])
    return kwargs


def _hyperparameters(config: TrainConfig, action_space: Any) -> dict[str, Any]:
    import numpy as np

    kwargs = dict(config.hyperparameters)
    noise = kwargs.get("action_noise")
    if noise is not None:
        from stable_baselines3.common.noise import (
            NormalActionNoise,
            OrnsteinUhlenbeckActionNoise,
        )

        kinds = {"normal": NormalActionNoise, "ornstein-uhlenbeck": OrnsteinUhlenbeckActionNoise}
        if not isinstance(noise, Mapping) or set(noise) != {"type", "sigma"} or noise["type"] not in kinds:
            raise ValueError(f"hyperparameters.action_noise must be {{type: normal|ornstein-uhlenbeck, sigma: s}}, got {noise!r}")
        size = int(np.prod(action_space.shape))
        kwargs["action_noise"] = kinds[noise["type"]](mean=np.zeros(size), sigma=float(noise["sigma"]) * np.ones(size))
    from agents.training.hyperparameters import schedule

    for key in ("learning_rate", "clip_range"):
        if key in kwargs:
            kwargs[key] = schedule(kwargs[key])
    if isinstance(kwargs.get("train_freq"), list):
        kwargs["train_freq"] = tuple(kwargs["train_freq"])
    return kwargs


def _setup_torch(config: TrainConfig) -> None:
    import torch

    torch.set_num_threads(config.torch_threads)
    torch.use_deterministic_algorithms(True)


def run_provenance(command: str | None) -> dict[str, Any]:
    """What a run records of how it was made: the command, the commit, the versions, the start time."""
    return {"command": command or "(python API)", "commit": git_commit(), "versions": versions(),
            "started": datetime.now(UTC).isoformat(timespec="seconds")}


def announce_config(config: Any, provenance: Mapping[str, Any]) -> str:
    """The run's ``config.yaml`` text (the resolved config under its provenance), printed as the run
    starts; the SB3 run and the learned rule's fit both begin with it."""
    text = _config_yaml(config, provenance)
    print(text, end="")
    return text


def _config_yaml(config: TrainConfig, provenance: Mapping[str, Any]) -> str:
    header = [f"# deadtime train: resolved config, {provenance['started']}",
              f"# command: {provenance['command']}",
              f"# commit: {provenance['commit']}",
              "# versions: " + ", ".join(f"{k} {v}" for k, v in provenance["versions"].items())]
    return "\n".join(header) + "\n" + yaml.safe_dump(config.to_dict(), sort_keys=False)


def _check_resumable(saved: TrainConfig, config: TrainConfig, run_dir: Path) -> None:
    changed = [f.name for f in dataclasses.fields(TrainConfig)
               if f.name not in _RESUMABLE_CHANGES and getattr(saved, f.name) != getattr(config, f.name)]
    if changed:
        raise ValueError(f"cannot resume {run_dir}: the config differs from the saved one in {', '.join(changed)}")


def checkpoint_steps(run_dir: Path) -> int:
    from agents.training.checkpoints import DamagedFileError, find_checkpoint

    try:
        checkpoint, _ = find_checkpoint(run_dir)
    except DamagedFileError:
        return 0
    return 0 if checkpoint is None else checkpoint.num_timesteps


# ----------------------------------------------------------------------------------- training
def train(
    config: TrainConfig,
    *,
    resume: bool = False,
    command: str | None = None,
    callbacks: Sequence[Any] = (),
) -> TrainResult:
    """Train a stable-baselines3 agent as the config says, in :func:`run_directory` ``(config)`` (a
    learned-rule config is fitted by :func:`agents.training.learned_rule.fit`).

    Everything that can refuse the config (its values, the environments, the model) is built before
    anything is written; a first SIGINT or SIGTERM ends the run at the next rollout boundary with a
    checkpoint (``status == "interrupted"``, ``stopped_by`` the signal).

    Parameters
    ----------
    config : TrainConfig
        The resolved config.
    resume : bool
        Continue exactly from the run's newest intact checkpoint (a fresh start if it has none yet).
    command : str, optional
        The command line, for the provenance records.
    callbacks : sequence of BaseCallback
        Extra stable-baselines3 callbacks (e.g. to interrupt a run in a test).

    Raises
    ------
    ValueError
        If the config is invalid or not a :class:`TrainConfig`, the run directory already holds a run and ``resume`` is False,
        ``resume`` is True with a config that differs from the run's, or a file of the run is damaged
        (:class:`agents.training.checkpoints.DamagedFileError`, naming it).
    """
    if not isinstance(config, TrainConfig):
        raise ValueError(f"train() trains a stable-baselines3 agent; a {config.algorithm} config is fitted by "  # noqa: TRY004
                         "agents.training.learned_rule.fit")
    from agents.files.lock import folder_lock

    validate(config)
    run_dir = run_directory(config)
    with folder_lock(run_dir, "train"):  # before the folder is checked: a second run on it is refused
        return _session(config, run_dir, resume, command, callbacks)


def _session(config: TrainConfig, run_dir: Path, resume: bool, command: str | None, callbacks: Sequence[Any]) -> TrainResult:
    """:func:`train` in ``run_dir``, whose lock is held."""
    from agents.training.callbacks import make_callbacks, save_model
    from agents.training.checkpoints import restore_state
    from agents.training.interrupts import StopRequest

    checkpoint = _existing_run(config, run_dir, resume)
    finished = _finished(run_dir, config) if resume else None
    if finished is not None:
        print(f"{run_dir} already finished {finished.num_timesteps} steps (raise total_timesteps to extend it)")
        return finished

    provenance = run_provenance(command)
    text = announce_config(config, provenance)
    _setup_torch(config)
    from stable_baselines3.common.utils import set_random_seed

    set_random_seed(config.seed)
    venv, eval_env = _environments(config)
    stop = StopRequest(_boundary(config))
    try:
        model, vecnormalize, state = _model(config, checkpoint, venv, str(run_dir / "tensorboard"))
        venv = model.get_env()
        resumed = None if checkpoint is None else {"periodic_checkpoint": checkpoint.periodic_checkpoint, "state": state}
        history = checkpoint.evaluations if checkpoint is not None else ()
        run_callbacks, validator, checkpointer = refused_as("eval_family", "the validation plant set", lambda: make_callbacks(
            run_dir, config.total_timesteps, eval_env, config.n_eval_episodes, config.eval_freq,
            config.eval_family, config.checkpoint_freq, config.progress_bar, vecnormalize, history, stop, resumed))
        if config.lagrangian is not None:
            from agents.training.lagrangian import MultiplierCallback

            run_callbacks = [*run_callbacks, MultiplierCallback(config.lagrangian_settings, run_dir)]
        _start_writing(run_dir, text, checkpoint)  # the config was accepted: now the run directory
        if state is not None:
            restore_state(state, model, vecnormalize)

        start_steps = model.num_timesteps
        started, cpu_started = time.perf_counter(), time.process_time()
        status = "interrupted"
        try:
            with stop:
                model.learn(total_timesteps=config.total_timesteps - start_steps, callback=[*run_callbacks, *callbacks],
                            reset_num_timesteps=checkpoint is None, tb_log_name="run", progress_bar=False)
            status = "interrupted" if checkpointer.stopped_at is not None else "finished"
        finally:
            train_seconds = time.perf_counter() - started
            checkpointed = checkpointer.written or (status == "finished" and config.checkpoint_freq > 0)  # saved below
            _write_run_json(run_dir, config, provenance, status, model.num_timesteps, start_steps, train_seconds,
                            time.process_time() - cpu_started, checkpoint is not None, checkpointed)
        if status == "finished":
            save_model(model, run_dir / "model.zip", vecnormalize)
            final = validator.validate(model).mean_cost
            if config.checkpoint_freq > 0:  # the final state, so that a larger total_timesteps can extend the run
                checkpointer.save()
    finally:
        _close(venv)
        eval_env.close()
    steps = model.num_timesteps - start_steps
    if status != "finished":
        return TrainResult(run_dir=run_dir, num_timesteps=checkpointer.stopped_at, session_steps=steps,
                           train_seconds=train_seconds, steps_per_second=steps / train_seconds if train_seconds > 0 else float("nan"),
                           best_cost=validator.best, final_cost=float("nan"), status=status, stopped_by=stop.signum)
    return TrainResult(run_dir=run_dir, num_timesteps=model.num_timesteps, session_steps=steps, train_seconds=train_seconds,
                       steps_per_second=steps / train_seconds if train_seconds > 0 else float("nan"),
                       best_cost=validator.best, final_cost=final)


def _boundary(config: TrainConfig) -> str:
    """When a stop request is served, for the line printed when the signal arrives."""
    if config.off_policy:
        return "after the current rollout and its gradient steps"
    n_steps = config.hyperparameters.get("n_steps", 2048 if config.algorithm == "PPO" else 5)
    return f"at the end of the current rollout (at most {n_steps * config.n_envs} steps and its update)"


def _existing_run(config: TrainConfig, run_dir: Path, resume: bool) -> Checkpoint | None:
    """Check (reading only) that the run directory fits the request; the checkpoint to resume from, if any."""
    from agents.training.checkpoints import find_checkpoint

    from agents.files.reader import read_record

    saved_config = run_dir / "config.yaml"
    checkpoint = None
    if resume and saved_config.is_file():
        _check_resumable(load_config(saved_config), config, run_dir)
        read_record(run_dir / "run.json", dict)  # rewritten when the session ends: a damaged one is named now
        checkpoint, note = find_checkpoint(run_dir)
        if note:
            print(f"deadtime train: {note}", file=sys.stderr)
        if checkpoint is None and _finished(run_dir, config) is None:
            _require_no_trained_steps(run_dir)
    elif not resume and (saved_config.exists() or (run_dir / "checkpoints").exists()):
        raise ValueError(f"{run_dir} already holds a run; pass --resume to continue it, or choose another --out")
    if checkpoint is not None and checkpoint.num_timesteps >= config.total_timesteps and not _finished(run_dir, config):
        raise ValueError(f"{run_dir}: the latest checkpoint has {checkpoint.num_timesteps} steps, "
                         f"total_timesteps is {config.total_timesteps}; nothing to resume")
    return checkpoint


def _require_no_trained_steps(run_dir: Path) -> None:
    """Refuse to resume from step 0 a run whose ``run.json`` records trained steps: its checkpoints are gone.

    A run stopped before its first checkpoint (``run.json``'s ``checkpointed`` false; a sweep's trial
    stopped by Ctrl-C early) has nothing to resume: it starts again from step 0, and says so.  A record
    without ``checkpointed`` (an older run) counts as checkpointed.

    Raises
    ------
    DamagedFileError
        Naming the run's ``checkpoints/`` folder and the steps ``run.json`` records.
    """
    from agents.files.reader import DamagedFileError, read_record

    record = read_record(run_dir / "run.json", dict) or {}
    steps = record.get("num_timesteps")
    if isinstance(steps, int) and steps > 0 and record.get("checkpointed") is False:
        print(f"deadtime train: {run_dir} was stopped after {steps} steps, before its first checkpoint: "
              "it starts again from step 0", file=sys.stderr)
    elif isinstance(steps, int) and steps > 0:
        raise DamagedFileError(f"{run_dir / 'checkpoints'} holds no checkpoint, but {run_dir / 'run.json'} records {steps} "
                               "trained steps: restore the checkpoints, or start a new run in another --out "
                               "(a run is never restarted from step 0 silently)")


def _start_writing(run_dir: Path, config_text: str, checkpoint: Checkpoint | None) -> None:
    """Create the run directory with its config; on resume, the validation history as of the checkpoint."""
    from agents.files.writer import write_json, write_text

    run_dir.mkdir(parents=True, exist_ok=True)
    write_text(run_dir / "config.yaml", config_text)  # on --resume: the same config, but total_timesteps may have grown
    if checkpoint is not None:
        write_json(run_dir / "evaluations.json", list(checkpoint.evaluations))


def _environments(config: TrainConfig) -> tuple[Any, Any]:
    """The training environments and the validation environment; ``env_kwargs`` errors name the key."""
    venv = refused_as("env_kwargs", config.env_id, lambda: make_vec_env(config))
    try:
        eval_env = refused_as("env_kwargs", config.env_id, lambda: make_env(config.env_id, config.env_kwargs))
    except ValueError:
        _close(venv)
        raise
    return venv, eval_env


def new_model(config: TrainConfig, venv: Any, tensorboard: str | None = None) -> Any:
    """A new stable-baselines3 model of ``config`` (algorithm, policy, hyperparameters, seed) on ``venv``."""
    algorithm = algorithm_class(config.algorithm)
    extra = {}
    if config.lagrangian is not None:  # reward and constraint cost stored apart (agents.training.lagrangian)
        from agents.training.lagrangian import CostReplayBuffer

        extra["replay_buffer_class"] = CostReplayBuffer
    return algorithm(config.policy, venv, seed=config.seed, device=config.device, verbose=0, tensorboard_log=tensorboard,
                     policy_kwargs=_policy_kwargs(config), **_hyperparameters(config, venv.action_space), **extra)


def _model(config: TrainConfig, checkpoint: Checkpoint | None, venv: Any, tensorboard: str) -> tuple[Any, Any, Any]:
    """``(model, vecnormalize, state)``: a new model on ``venv`` (state None), or the checkpoint's, with its
    replay buffer, statistics and training state (:func:`agents.training.checkpoints.capture_state`) to restore."""
    from stable_baselines3.common.vec_env import VecNormalize

    if checkpoint is not None:
        return _restored_model(config, checkpoint, venv, tensorboard)
    if config.normalize:
        venv = VecNormalize(venv, norm_obs=True, norm_reward=config.normalize_reward)
    model = refused_as("hyperparameters or policy_kwargs", config.algorithm, lambda: new_model(config, venv, tensorboard))
    model.deadtime_vecnormalize = config.normalize  # saved with the model: load_policy requires the statistics
    return model, venv if config.normalize else None, None


def _restored_model(config: TrainConfig, checkpoint: Checkpoint, venv: Any, tensorboard: str) -> tuple[Any, Any, Any]:
    from agents.training.checkpoints import DamagedFileError, load_file, read_pickle

    algorithm = algorithm_class(config.algorithm)
    vecnormalize = None
    if config.normalize:
        if checkpoint.path("vecnormalize") is None:
            raise DamagedFileError(f"{checkpoint.manifest} names no vecnormalize file, but the run normalizes observations")
        vecnormalize = load_file(checkpoint.path("vecnormalize"), read_pickle)
        vecnormalize.set_venv(venv)
        vecnormalize.training = True
        venv = vecnormalize
    model = load_file(checkpoint.path("model"), lambda path: algorithm.load(
        path, env=venv, device=config.device, tensorboard_log=tensorboard, force_reset=False))
    if checkpoint.path("replay_buffer") is not None:
        load_file(checkpoint.path("replay_buffer"), model.load_replay_buffer)
    state = None
    if checkpoint.path("state") is not None:
        state = load_file(checkpoint.path("state"), read_pickle)
    else:  # a checkpoint of the first format: no random states to restore
        print(f"deadtime train: {checkpoint.manifest} holds no training state (an older format); "
              "resuming reseeded with seed + num_timesteps, not as the uninterrupted run", file=sys.stderr)
        model.set_random_seed(config.seed + model.num_timesteps)
        model._last_obs = None  # noqa: SLF001  (the environments restart)
    return model, vecnormalize, state


def _close(venv: Any) -> None:
    """Close the training environments; subprocess workers may already be gone after Ctrl-C."""
    try:
        venv.close()
    except (EOFError, BrokenPipeError, ConnectionResetError):
        pass


def _finished(run_dir: Path, config: TrainConfig) -> TrainResult | None:
    """The result of a run that already reached ``config.total_timesteps``, or None."""
    from agents.files.reader import read_json, read_record

    record = read_record(run_dir / "run.json", dict)
    if not (run_dir / "evaluations.json").is_file():
        return None
    evaluations = read_json(run_dir / "evaluations.json", list)
    if record is None or record.get("status") != "finished" or record.get("num_timesteps", 0) < config.total_timesteps:
        return None
    return TrainResult(run_dir=run_dir, num_timesteps=int(record["num_timesteps"]), session_steps=0, train_seconds=0.0,
                       steps_per_second=float("nan"),
                       best_cost=min(e["mean_cost"] for e in evaluations), final_cost=evaluations[-1]["mean_cost"])


def _write_run_json(run_dir: Path, config: TrainConfig, provenance: Mapping[str, Any], status: str,
                    num_timesteps: int, start_steps: int, train_seconds: float, cpu_seconds: float,
                    resumed: bool, checkpointed: bool) -> None:
    """Record the run; ``cpu_seconds`` is the training process's own (not its subprocess workers').

    ``checkpointed`` (whether this session wrote a checkpoint) is recorded as whether the run ever
    wrote one: a run stopped before its first checkpoint has nothing to resume and starts again.
    """
    from agents.files.reader import read_record
    from agents.files.writer import write_json

    path = run_dir / "run.json"
    previous = read_record(path, dict) or {}
    segment = {"command": provenance["command"], "commit": provenance["commit"], "started": provenance["started"],
               "status": status, "resumed": resumed, "from_timesteps": start_steps,
               "num_timesteps": num_timesteps, "train_seconds": round(train_seconds, 3),
               "cpu_seconds": round(cpu_seconds, 3),
               "steps_per_second": round((num_timesteps - start_steps) / train_seconds, 2) if train_seconds > 0 else None,
               "finished_at": datetime.now(UTC).isoformat(timespec="seconds")}
    segments = [*previous.get("segments", []), segment]
    write_json(path, {
        "algorithm": config.algorithm, "env_id": config.env_id, "seed": config.seed,
        "status": status, "num_timesteps": num_timesteps, "total_timesteps": config.total_timesteps,
        "checkpointed": checkpointed or resumed or previous.get("checkpointed", False),
        "command": provenance["command"], "commit": provenance["commit"], "versions": provenance["versions"],
        "train_seconds": round(sum(s["train_seconds"] for s in segments), 3),
        "segments": segments,
    })
