"""Observation-normalization statistics as data: ``<stem>.normalization.json`` beside a saved agent.

An agent trained on normalized observations (``normalize: true``, stable-baselines3's ``VecNormalize``)
is played with the statistics it was trained with.  They are saved as JSON numbers (which read back
exactly): ``{"format": 1, "mean": [...], "var": [...], "count", "epsilon", "clip_obs"}``, and applied
as ``VecNormalize.normalize_obs`` does, ``clip((obs - mean) / sqrt(var + epsilon), -clip_obs,
clip_obs)`` in float32 (:class:`Normalization`).  Reading them executes nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.reader import FileProblem, read_json
from agents.files.writer import write_json

__all__ = ["FORMAT", "Normalization", "read_normalization", "statistics_record", "write_normalization"]

FORMAT = 1


@dataclass(frozen=True)
class Normalization:
    """Observation statistics, not updated while playing."""

    mean: np.ndarray
    var: np.ndarray
    count: float
    epsilon: float
    clip_obs: float

    def normalize_obs(self, observation: np.ndarray) -> np.ndarray:
        """The normalized observation (float32), as ``VecNormalize.normalize_obs``."""
        values = np.clip((observation - self.mean) / np.sqrt(self.var + self.epsilon), -self.clip_obs, self.clip_obs)
        return values.astype(np.float32)


def statistics_record(vecnormalize: Any) -> dict[str, Any]:
    """The JSON record of a ``VecNormalize``'s observation statistics.

    Raises
    ------
    ValueError
        For statistics this record cannot hold (dictionary observations, or not normalizing them).
    """
    rms = vecnormalize.obs_rms
    if not vecnormalize.norm_obs or isinstance(rms, dict):
        raise ValueError("only the statistics of normalized array observations can be saved as data")
    return {"format": FORMAT, "mean": np.asarray(rms.mean, dtype=float).tolist(),
            "var": np.asarray(rms.var, dtype=float).tolist(), "count": float(rms.count),
            "epsilon": float(vecnormalize.epsilon), "clip_obs": float(vecnormalize.clip_obs)}


def write_normalization(path: Path, vecnormalize: Any) -> Path:
    """Write the statistics of ``vecnormalize`` to ``path`` (JSON), atomically."""
    return write_json(path, statistics_record(vecnormalize))


def read_normalization(path: Path) -> Normalization:
    """The statistics of ``path``.

    Raises
    ------
    ValueError
        Naming the file, if it is not a record of :func:`statistics_record`.
    """
    try:
        data = read_json(path, dict)
    except FileProblem as error:
        raise ValueError(str(error)) from None
    try:
        if data.get("format") != FORMAT:
            raise ValueError(f"format {data.get('format')!r}, not {FORMAT}")
        mean, var = (np.asarray(data[key], dtype=float) for key in ("mean", "var"))
        numbers = [float(data[key]) for key in ("count", "epsilon", "clip_obs")]
        if mean.ndim != 1 or mean.shape != var.shape or not (np.all(np.isfinite(mean)) and np.all(var >= 0)):
            raise ValueError("mean and var must be finite vectors of one length, var >= 0")
        if not all(math.isfinite(x) and x > 0 for x in numbers):
            raise ValueError("count, epsilon and clip_obs must be finite numbers > 0")
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{path} is damaged: not observation statistics ({error})") from None
    return Normalization(mean, var, *numbers)
