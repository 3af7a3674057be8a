"""The stable-baselines3 callback of a sweep's trial: the step count reported to Ray Tune.

Imported by the trial (:func:`agents.sweeps.run.trial_function`), in Tune's worker, so that the
sweep's driver never loads stable-baselines3 and torch.
"""

from __future__ import annotations

from ray import tune
from stable_baselines3.common.callbacks import BaseCallback

__all__ = ["REPORTS_PER_TRIAL", "TuneReporter"]

REPORTS_PER_TRIAL = 10
"""Progress reports to Tune per trial, besides the final one."""


class TuneReporter(BaseCallback):
    """Reports ``{"timesteps": n, "finished": False}`` to Tune ``REPORTS_PER_TRIAL`` times in a run."""

    def __init__(self, total_timesteps: int) -> None:
        super().__init__()
        self.total_timesteps = total_timesteps
        self.every = max(1, total_timesteps // REPORTS_PER_TRIAL)

    def _on_step(self) -> bool:
        if self.model.num_timesteps % self.every == 0 and self.model.num_timesteps < self.total_timesteps:
            tune.report({"timesteps": self.model.num_timesteps, "finished": False})
        return True
