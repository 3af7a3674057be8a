"""stable-baselines3 callbacks of ``deadtime train``: progress, validation, atomic checkpoints.

The callbacks are module-level classes (:class:`Validator`, :class:`Checkpointer`, :class:`Progress`);
:func:`make_callbacks` builds the set of a run.  This module imports stable-baselines3 (and so
torch): ``deadtime train`` imports it inside ``run``, never while the command line is parsed.

Validation (:func:`agents.training.validation.validate_policy`, re-exported here) runs one
deterministic episode per plant of the validation set ``envs.systems.plant_sets.plant_set(family,
"validation", n)`` (never a test set), resetting with ``options={"plant": p}`` and the seed
``VALIDATION_SEED + k`` (3_000_000 + k) for plant ``k``.  Training environments use the seeds
``seed + i`` of a config's small integer seed, so the two never meet.  Environments without plant
sets (any non-``DeadTime`` id) are validated on ``n`` episodes reset with those seeds alone.

Checkpoints (:mod:`agents.training.checkpoints`) are written at the start of a rollout, after the previous
rollout was trained on, every ``checkpoint_freq`` steps, and at the next rollout start after a
SIGINT/SIGTERM (:class:`agents.training.interrupts.StopRequest`), after which training stops.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from agents.training.checkpoints import restore_action_noise, save_checkpoint
from agents.files.writer import atomic_write, write_json, write_text
from agents.training.validation import VALIDATION_SEED, ValidationResult, action_masks, validate_policy, validation_plants

__all__ = [
    "VALIDATION_SEED",
    "Checkpointer",
    "Progress",
    "ValidationResult",
    "Validator",
    "atomic_write",
    "make_callbacks",
    "save_model",
    "validate_policy",
    "validation_plants",
    "write_json",
    "write_text",
]


def save_model(model: Any, path: str | Path, vecnormalize: Any = None) -> Path:
    """Save ``model`` to ``path`` (a ``.zip``) atomically, and the ``VecNormalize`` statistics beside it.

    The statistics go to ``<stem>.normalization.json`` as JSON numbers (:mod:`agents.training.normalization`;
    read by :func:`agents.training.policies.load_policy`), written before the model, whose
    ``deadtime_vecnormalize`` attribute says that they are needed; then the manifest
    ``<stem>.manifest.json`` records both (:mod:`agents.training.manifest`).
    """
    from agents.training.manifest import write_manifest
    from agents.training.normalization import write_normalization

    path = Path(path)
    files = []
    if vecnormalize is not None:
        files.append(write_normalization(path.with_suffix(".normalization.json"), vecnormalize))
    files.insert(0, atomic_write(path, model.save))
    write_manifest(path, files)
    return path


# ----------------------------------------------------------------------------------- callbacks
class Validator(BaseCallback):
    """Validation every ``eval_freq`` steps; keeps ``best_model.zip`` and ``evaluations.json``.

    ``history`` holds the validations of the run so far (a resumed run's), ``plants`` the validation
    plants (:func:`validation_plants`); :meth:`validate` runs one validation.
    """

    def __init__(self, run_dir: Path, total_timesteps: int, eval_env: Any, n_eval_episodes: int, eval_freq: int,
                 plants: list[Any] | None, vecnormalize: Any = None, history: Sequence[dict[str, Any]] = ()) -> None:
        super().__init__()
        self.run_dir, self.total_timesteps, self.eval_freq = run_dir, total_timesteps, eval_freq
        self.eval_env, self.n_eval_episodes, self.vecnormalize = eval_env, n_eval_episodes, vecnormalize
        self.plants = plants
        self.history = list(history)
        self.best = min((entry["mean_cost"] for entry in self.history), default=np.inf)
        self.last = self.history[-1]["num_timesteps"] if self.history else 0

    def _on_step(self) -> bool:
        steps = self.model.num_timesteps
        # the last step is validated once, after the last update, by the end of training
        if self.eval_freq > 0 and steps - self.last >= self.eval_freq and steps < self.total_timesteps:
            self.validate(self.model)
        return True

    def _predict(self, observation: np.ndarray) -> np.ndarray:
        if self.vecnormalize is not None:
            observation = self.vecnormalize.normalize_obs(observation)
        masks = action_masks(self.eval_env)
        if masks is None:
            return self.model.predict(observation, deterministic=True)[0]
        return self.model.predict(observation, deterministic=True, action_masks=masks)[0]

    def validate(self, model: Any) -> ValidationResult:
        """Validate ``model`` now: log, print and record the result, and keep the best model."""
        self.model = model
        self.last = model.num_timesteps
        result = validate_policy(self._predict, self.eval_env, self.n_eval_episodes, self.plants, model.num_timesteps)
        self.history.append({key: value for key, value in result.to_dict().items() if key != "costs"})
        if result.mean_cost < self.best:
            self.best = result.mean_cost
            save_model(model, self.run_dir / "best_model.zip", self.vecnormalize)
        write_json(self.run_dir / "evaluations.json", self.history)
        model.logger.record("eval/mean_cost", result.mean_cost)
        model.logger.record("eval/median_cost", result.median_cost)
        if result.violation_rate is not None:
            model.logger.record("eval/violation_rate", result.violation_rate)
        model.logger.record("eval/best_mean_cost", self.best)
        model.logger.dump(model.num_timesteps)
        from tqdm import tqdm

        violations = "" if result.violation_rate is None else f", violations {result.violation_rate:.0%}"
        tqdm.write(f"step {model.num_timesteps}: validation mean cost {result.mean_cost:.6g} "
                   f"(median {result.median_cost:.6g}{violations}); best {self.best:.6g}")
        return result


class Checkpointer(BaseCallback):
    """Checkpoints at rollout starts every ``checkpoint_freq`` steps, and one after a stop request.

    Each checkpoint holds ``validator``'s history; ``stop`` and ``resumed`` are those of :func:`make_callbacks`.
    """

    def __init__(self, run_dir: Path, checkpoint_freq: int, validator: Validator, vecnormalize: Any = None,
                 stop: Any = None, resumed: Mapping[str, Any] | None = None) -> None:
        super().__init__()
        self.run_dir, self.checkpoint_freq, self.validator = run_dir, checkpoint_freq, validator
        self.vecnormalize, self.stop, self.resumed = vecnormalize, stop, resumed

    def _init_callback(self) -> None:
        resumed = self.resumed
        self.periodic = self.model.num_timesteps if resumed is None else int(resumed["periodic_checkpoint"])
        self.directory = self.run_dir / "checkpoints"
        self.stopping = False
        self.stopped_at: int | None = None
        self.written = False  # whether this session wrote a checkpoint

    def _on_training_start(self) -> None:
        if self.resumed is not None and self.resumed.get("state") is not None:
            restore_action_noise(self.resumed["state"], self.model)

    def _on_step(self) -> bool:
        return not self.stopping  # False ends learn() one step after the stop checkpoint

    def _on_rollout_start(self) -> None:
        due = self.checkpoint_freq > 0 and self.model.num_timesteps - self.periodic >= self.checkpoint_freq
        requested = self.stop is not None and self.stop.requested and not self.stopping
        if due or requested:
            self.save(periodic=due)
        if requested:
            self.stopping, self.stopped_at = True, self.model.num_timesteps

    def save(self, periodic: bool = True) -> Path:
        """Write a checkpoint now (``periodic``: it counts as the periodic one)."""
        if periodic:
            self.periodic = self.model.num_timesteps
        path = save_checkpoint(self.directory, self.model, self.vecnormalize, self.validator.history, self.periodic)
        self.written = True
        return path


class Progress(BaseCallback):
    """A tqdm bar over the run's total timesteps (stable-baselines3's own needs ``rich``)."""

    def __init__(self, total_timesteps: int) -> None:
        super().__init__()
        self.total_timesteps = total_timesteps

    def _on_training_start(self) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=self.total_timesteps, initial=self.model.num_timesteps, unit="step",
                        dynamic_ncols=True, smoothing=0.1)

    def _on_step(self) -> bool:
        self.bar.update(self.model.num_timesteps - self.bar.n)
        return True

    def _on_training_end(self) -> None:
        self.bar.close()


def make_callbacks(
    run_dir: Path,
    total_timesteps: int,
    eval_env: Any,
    n_eval_episodes: int,
    eval_freq: int,
    eval_family: str | None,
    checkpoint_freq: int,
    progress_bar: bool,
    vecnormalize: Any = None,
    history: Sequence[dict[str, Any]] = (),
    stop: Any = None,
    resumed: Mapping[str, Any] | None = None,
) -> tuple[list[Any], Validator, Checkpointer]:
    """The callbacks of a run: ``(callbacks, validator, checkpointer)``.

    ``validator.validate(model)`` runs one validation; ``checkpointer.save()`` writes a checkpoint.
    ``stop`` is an :class:`agents.training.interrupts.StopRequest` (a checkpoint at the next rollout start, then
    a stop); ``resumed`` the checkpoint's ``periodic_checkpoint`` step and training ``state``
    (:func:`agents.training.checkpoints.capture_state`), whose action noise is put back when training starts.
    The validation plants are drawn when this is called, so a bad ``eval_family`` fails here.
    """
    plants = validation_plants(eval_env, n_eval_episodes, eval_family)
    validator = Validator(run_dir, total_timesteps, eval_env, n_eval_episodes, eval_freq, plants, vecnormalize, history)
    checkpointer = Checkpointer(run_dir, checkpoint_freq, validator, vecnormalize, stop, resumed)
    callbacks: list[Any] = [validator, checkpointer]
    if progress_bar:
        callbacks.append(Progress(total_timesteps))
    return callbacks, validator, checkpointer
