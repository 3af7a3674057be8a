"""Plants across regimes, labelled by the oracle's fast search: the data of the risk-conditioned learner.

Plant ``k`` of a stream (a structure and an entropy) draws its own regime and its own reset seed from
``numpy.random.default_rng([entropy, structure index, k])``: ``noise_std`` log-uniform over the
config's range, the experiments' price ``weights.production`` from its choices (and, where the
environment has the option, a sensor ``quantization`` for a share of the plants).  The plant is then
drawn by the environment's own generator of that regime (``env.reset(seed=...)``, the structure's own
plant family) and labelled by :func:`agents.training.learned_rule._label` with the fast search: its
observation, the oracle's action and the feasibility boundary's action (the least conservative
feasible design), in one search.  Plant ``k`` does not depend on how many are drawn.

The labels are cached :data:`CHUNK` plants a file (``labels/<STRUCTURE>/<stream>-<first>.json``,
each written atomically when complete, with its checksum: :func:`agents.training.learned_rule._write_chunk`),
so an interrupted labelling continues from the files written.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["CHUNK", "STRUCTURES", "Regime", "draw", "label_stream", "load_stream", "records_arrays"]

CHUNK = 100
"""Plants per cached file of labels."""

STRUCTURES = ("PID", "FPPI", "MSP", "PI")
"""The structures, in the order that enters each plant's seed."""


@dataclass(frozen=True)
class Regime:
    """The drawn regime of one plant: its environment's keyword arguments."""

    noise_std: float
    production: float
    quantization: float = 0.0

    def env_kwargs(self, base: Mapping[str, Any]) -> dict[str, Any]:
        kwargs = {**base, "noise_std": self.noise_std, "weights": {"production": self.production}}
        if self.quantization > 0:
            kwargs["quantization"] = self.quantization
        return kwargs


def draw(entropy: int, structure: str, index: int, noise_range: tuple[float, float], productions: tuple[float, ...],
         quantized_share: float = 0.0, quantization_range: tuple[float, float] = (0.1, 3.0)) -> tuple[Regime, int]:
    """``(regime, reset seed)`` of plant ``index`` of the stream ``entropy`` of ``structure`` (module docstring);
    a quantized plant's step is log-uniform over ``quantization_range`` times its noise."""
    rng = np.random.default_rng([int(entropy), STRUCTURES.index(structure), int(index)])
    low, high = (math.log(v) for v in noise_range)
    noise = float(math.exp(rng.uniform(low, high)))
    production = float(productions[int(rng.integers(len(productions)))])
    quantization = 0.0
    if rng.uniform() < quantized_share:
        q_low, q_high = (math.log(v) for v in quantization_range)
        quantization = noise * float(math.exp(rng.uniform(q_low, q_high)))
    seed = int(rng.integers(2**62))
    return Regime(noise, production, quantization), seed


def _chunk_path(folder: Path, structure: str, stream: str, first: int) -> Path:
    return folder / structure / f"{stream}-{first:06d}.json"


def label_stream(folder: Path, env_id: str, structure: str, stream: str, entropy: int, count: int, *,
                 base_kwargs: Mapping[str, Any], draw_kwargs: Mapping[str, Any], regime: Regime | None = None,
                 log: Any = sys.stderr) -> list[dict[str, Any]]:
    """The first ``count`` labelled plants of a stream (from the cache where there, the rest labelled
    and cached); ``regime`` fixes every plant's regime (a validation regime), else each draws its own."""
    from agents.environments import make_env
    from agents.training.learned_rule import _cached_chunk, _label, _write_chunk

    records: list[dict[str, Any]] = []
    started, labelled = time.perf_counter(), 0
    envs: dict[Regime, Any] = {}
    for first in range(0, count, CHUNK):
        indices = range(first, min(first + CHUNK, count))
        draws = [draw(entropy, structure, k, **draw_kwargs) for k in indices]
        if regime is not None:
            draws = [(regime, seed) for _, seed in draws]
        path = _chunk_path(folder, structure, stream, first)
        chunk = _cached_chunk(path, [seed for _, seed in draws])
        for k, (drawn, seed) in list(zip(indices, draws))[len(chunk):]:
            if drawn not in envs:
                if len(envs) > 8:
                    envs.pop(next(iter(envs))).close()
                envs[drawn] = make_env(env_id, drawn.env_kwargs(base_kwargs))
            record = _label(envs[drawn], seed, k, "fast")
            record.update(noise_std=drawn.noise_std, production=drawn.production, quantization=drawn.quantization)
            chunk.append(record)
            labelled += 1
        if labelled and len(chunk) == len(draws):
            _write_chunk(path, chunk)
            seconds = time.perf_counter() - started
            print(f"{structure} {stream}: {first + len(chunk)}/{count} plants, {labelled / seconds:.2f} labels/s",
                  file=log, flush=True)
        records += chunk
    for env in envs.values():
        env.close()
    return records


def load_stream(folder: Path, structure: str, stream: str) -> list[dict[str, Any]]:
    """Every complete cached chunk of a stream, in order (without labelling)."""
    from agents.files.reader import read_json

    records: list[dict[str, Any]] = []
    for path in sorted((folder / structure).glob(f"{stream}-*.json")):
        records += read_json(path, dict)["records"]
    return records


def records_arrays(records: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """The records as arrays: ``observation`` (n x d), ``action``, ``boundary`` (the boundary's action;
    NaN where no design is feasible), ``direction`` (+1 where a larger action is the more conservative design), ``noise_std``, ``production``,
    ``quantization``."""
    boundary = [np.nan if r.get("boundary_action") is None else r["boundary_action"] for r in records]
    return {"observation": np.array([r["observation"] for r in records], dtype=float),
            "action": np.array([r["action"] for r in records], dtype=float),
            "boundary": np.array(boundary, dtype=float),
            "noise_std": np.array([r["noise_std"] for r in records], dtype=float),
            "direction": np.array([r["direction"] for r in records], dtype=float),
            "production": np.array([r["production"] for r in records], dtype=float),
            "quantization": np.array([r["quantization"] for r in records], dtype=float)}
