"""The documented upper limits of what ``deadtime`` accepts, in one place.

Each limit is far above honest use (the defaults and the documented runs stay orders of magnitude
below) and low enough that a value just under it still runs in bounded time and memory; a value
above is refused before anything is computed or written, in one line naming the field and the
limit (exit status 2 on the command line).  The help texts quote these constants.

Three limits live beside what they bound: the size of a plant is a property of the plant, so
:data:`envs.systems.plants.MAX_COEFFICIENTS` (101 coefficients in ``num`` and in ``den``) sits with its
other documented ranges (``GAIN_RANGE``, ``TIME_SCALE_RANGE``); a learned rule's training plants are
bounded by the stride of its seeds, :data:`agents.training.learned_rule_config.MAX_TRAINING_PLANTS`;
the samples of a run on a sampled process by :data:`envs.process.protocol.MAX_SAMPLES_PER_SETTLING`
(100000 samples in a settling time).

This module imports no numerics, so that the command line's help texts quote it without loading
numpy, envs or torch.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "MAX_BUFFER_SIZE",
    "MAX_CSV_FIELD",
    "MAX_ENVS",
    "MAX_EVAL_EPISODES",
    "MAX_FILE_BYTES",
    "MAX_LAYERS",
    "MAX_LAYER_WIDTH",
    "MAX_NESTING",
    "MAX_RESAMPLES",
    "MAX_SEEDS",
    "MAX_PADE_ORDER",
    "MAX_REFERENCE_SAMPLES",
    "MAX_TEST_PLANTS",
    "MAX_TIMESTEPS",
    "MAX_WORKERS",
    "MAX_YAML_NODES",
    "require_at_most",
]

MAX_NESTING = 32
"""Levels of nesting of a JSON argument (``--plant``, ``--env-kwargs``, ...) or a YAML file: the
deepest honest input (a sweep's ``env_kwargs`` mapping of a mapping of a list) has five.  Deeper
input is refused before Python's recursion limit is reached."""

MAX_YAML_NODES = 100_000
"""Values (scalars, lists and mappings) of a YAML file or ``key=value`` override, counted with its
aliases expanded (each ``*name`` counts the whole value it repeats): a config file has about a
hundred.  An alias bomb ("billion laughs": a few lines that expand to billions of values) is refused
in milliseconds, and its value is never expanded nor printed."""

MAX_FILE_BYTES = 1 << 30
"""Bytes of one file that ``deadtime`` reads back (:mod:`agents.files.reader`): a config, a record, a table
of per-plant costs, the evaluation cache.  The largest honest file, the cache of an evaluation of
10000 plants, holds tens of megabytes."""

MAX_CSV_FIELD = 65_536
"""Characters of one field of a table that ``deadtime`` reads back (``per_plant.csv``): the longest
honest field, a plant's JSON, holds at most 202 coefficients (a few kilobytes)."""

MAX_SEEDS = 1_000
"""Seeds of one trial group of a sweep (``seeds: {count: ...}`` or a list): one training run each."""

MAX_TEST_PLANTS = 10_000
"""Test plants of an evaluation: ``deadtime evaluate --n`` (and the entries of ``--plants``), a sweep's
``evaluation.n``.  The oracle's search takes about a second per plant."""

MAX_RESAMPLES = 100_000
"""Bootstrap resamples of an evaluation (``--resamples``, a sweep's ``evaluation.resamples``); the
bootstrap holds ``resamples x plants`` indices at once (default 2000)."""

MAX_WORKERS = 64
"""Processes of ``deadtime evaluate --workers``: each holds the environment and the oracle's compiled
code, about 270 MB; one per core is the honest use."""

MAX_TIMESTEPS = 100_000_000
"""Training steps of one run (``total_timesteps``): the configs train 10^4 to 10^6; at the measured tens
to hundreds of steps per second, 10^8 steps is days of training."""

MAX_PADE_ORDER = 14
"""Order of the Padé approximation of the dead time in ``deadtime bench``'s python-control reference
(``--pade-order``, default 8).  Measured on ``1/(10s+1) e^{-2s}`` with a PI: orders 8 to 14 give the
same IAEs within 0.1%, order 16 drifts by 1 to 3% (the coefficients pass 10^20 and the simulation loses
its digits), order 20 gives an infinite IAE, and higher orders divide by zero."""

MAX_REFERENCE_SAMPLES = 10_000
"""Samples per plant time scale of ``deadtime bench``'s python-control reference (``--reference-samples``,
default 50): over its horizon of up to 1280 time scales a simulation holds 10^7 samples at the limit."""

MAX_ENVS = 256
"""Training environments of one run (``n_envs``): one environment per core is the honest use."""

MAX_EVAL_EPISODES = 10_000
"""Validation episodes of one evaluation during training (``n_eval_episodes``, one validation plant
each), validation plants of a learned rule (``validation_plants``), agents' replays of ``deadtime
regimes --behaviour``."""

MAX_BUFFER_SIZE = 10_000_000
"""Transitions of an off-policy replay buffer (``hyperparameters.buffer_size``; stable-baselines3
allocates it whole when the model is built; its default is 1,000,000), of an on-policy rollout
(``hyperparameters.n_steps * n_envs``), and of a minibatch (``hyperparameters.batch_size``)."""

MAX_LAYER_WIDTH = 1_024
"""Units of one hidden layer of a policy or value network (``policy_kwargs.net_arch``; the configs use 64 to 256)."""

MAX_LAYERS = 8
"""Hidden layers of one network (``policy_kwargs.net_arch``)."""


def require_at_most(value: Any, limit: int, name: str) -> None:
    """Refuse a number above its documented ``limit``, naming ``name``.

    Other checks (type, sign) are the caller's; a value that is not a number passes.

    >>> require_at_most(10**12, MAX_TEST_PLANTS, "--n")
    Traceback (most recent call last):
    ValueError: --n must be at most 10000 (the documented limit, agents/limits.py), got 1000000000000
    """
    try:
        above = value > limit
    except TypeError:
        return
    if above:
        raise ValueError(f"{name} must be at most {limit} (the documented limit, agents/limits.py), got {value!r}")
