"""Shared test helpers of the training tests."""

from __future__ import annotations

import os
import signal

import pytest


@pytest.fixture
def sigint_at():
    """A callback class: ``sigint_at(step)`` sends SIGINT to this process (as Ctrl-C would) when the
    model reaches ``step`` timesteps."""
    from stable_baselines3.common.callbacks import BaseCallback

    class SigintAt(BaseCallback):
        def __init__(self, step: int) -> None:
            super().__init__()
            self.step = step

        def _on_step(self) -> bool:
            if self.model.num_timesteps == self.step:
                os.kill(os.getpid(), signal.SIGINT)
            return True

    return SigintAt
