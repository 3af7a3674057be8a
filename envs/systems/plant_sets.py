"""Fixed plant sets for validation and evaluation, disjoint from the plants of training.

Training plants come from the environment's own generator, seeded by the integer the user passes to
``reset`` (``numpy.random.default_rng(seed)``, whose seed sequence has an empty spawn key).  The
fixed sets come from :class:`numpy.random.SeedSequence` streams with the entropy
:data:`PLANT_SET_ENTROPY` and the spawn key ``(split, family)`` (indices into :data:`SPLITS` and
:data:`envs.systems.families.FAMILIES`).  A non-empty spawn key makes a stream that no integer seed
reproduces, so the sets are never drawn in training, whatever seed the training uses:

* ``"validation"``: for model selection during training (``deadtime train``'s periodic evaluation);
* ``"test"``: the held-out set of ``deadtime evaluate``, never looked at during development.

The ``i``-th plant of a set does not depend on how many plants are asked for, so a set of 100 plants
starts with the set of 10.  The papers' benchmark batches (:func:`benchmark_set`) are evaluated
beside the random sets.
"""

from __future__ import annotations

import numpy as np

from envs.systems.families import FAMILIES, sample_plant
from envs.systems.benchmark_batches import benchmark_plants
from envs.systems.plants import Plant

__all__ = ["PLANT_SET_ENTROPY", "SPLITS", "plant_set", "benchmark_set"]

PLANT_SET_ENTROPY = 2026_11_22
SPLITS: tuple[str, ...] = ("validation", "test")


def plant_set(family: str, split: str, n: int, config: object = None) -> list[Plant]:
    """The first ``n`` plants of the fixed ``split`` set of ``family``.

    Parameters
    ----------
    family : str
        One of :data:`envs.systems.families.FAMILIES`.
    split : {"validation", "test"}
    n : int
        Number of plants (>= 0).
    config : family config, optional
        As for :func:`envs.systems.families.sample_plant`.

    Raises
    ------
    ValueError
        For an unknown family or split, or a negative ``n``.
    """
    if split not in SPLITS:
        raise ValueError(f"unknown plant set split {split!r}; valid: {', '.join(SPLITS)}")
    if family not in FAMILIES:
        raise ValueError(f"unknown plant family {family!r}; valid families: {', '.join(FAMILIES)}")
    if isinstance(n, bool) or int(n) != n or n < 0:
        raise ValueError(f"n must be an integer >= 0, got {n!r}")
    key = (SPLITS.index(split), FAMILIES.index(family))
    rng = np.random.default_rng(np.random.SeedSequence(PLANT_SET_ENTROPY, spawn_key=key))
    return [sample_plant(family, rng, config) for _ in range(int(n))]


def benchmark_set(structure: str) -> dict[str, Plant]:
    """The papers' benchmark plants for a controller structure, by name.

    ``"pid"`` and ``"fppi"``: Gorez-Klan P1, P2 and Ingimundarson's seven stable processes;
    ``"msp"``: Ingimundarson's eight integrating processes (see
    :func:`envs.systems.benchmark_batches.benchmark_plants`).
    """
    from envs.structures import structure as structure_named  # the structures sit above the plants

    return benchmark_plants(structure_named(structure).plant_kind)
