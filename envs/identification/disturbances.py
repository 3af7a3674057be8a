"""Disturbances of an experiment beyond white measurement noise: a slow drift, an unmeasured load.

The experiments of :mod:`envs.identification.experiments` measure ``y + n`` with ``n`` white
(:class:`~envs.identification.noise.MeasurementNoise`).  A plant's measurement also moves
for reasons the experiment does not cause; :class:`Disturbances` adds, as options, each with a
level in units of the output (the experiments' amplitudes are relative to a unit change of it):

``drift``
    a random walk ``d_k = level sqrt(dt/T) (z_1 + .. + z_k)``: after one time scale ``T`` (the
    plant's ``T_ar``) it has moved by ``level`` (standard deviation); slow, unlike the white noise,
    so it shifts the levels and areas the identification reads and defeats the steady-state tests.
``load``
    an unmeasured step at the plant's input at a time uniform over the first
    :data:`LOAD_SPAN` time scales of the experiment (or its whole length if shorter), of either
    sign with equal probability: the output's response to it, ``level`` in steady state for a
    self-regulating plant (an input step of ``level/K``), a ramp of ``level`` per ``T`` for an
    integrating one (``level/(K_v T)``).

Both enter where the controller and the identification see them, the measurement (a load at the
input moves the output by ``G(s) l``, which adds to the response of the experiment's own input:
the loop is linear), held over each sample as the noise is: in closed loop the controller then sees
a staircase of the continuous ``G l``, which differs from the loop simulated with the load at the
plant input by an error of first order in ``dt`` (3.4e-4 of a unit step for a load of 0.3 at
``T/200``; the tests).  The ``true_output`` of a result stays the response to the experiment's own
input: what the experiment makes the plant do, which the excursion limit bounds and the production
cost charges (:func:`envs.analysis.scoring.score`).

Randomness: an experiment's disturbances come from streams of their own, spawned from the seed of
its noise's child stream (``SeedSequence(seed, spawn_key=(1,))`` for the drift, ``(2,)`` for the
load), so they take nothing more from the episode's generator, and the white noise of every sample
is the same with or without them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from envs.identification.noise import MeasurementNoise
from envs.validation import require_number

__all__ = ["DISTURBANCE_KINDS", "LOAD_SPAN", "Disturbances", "DisturbedNoise"]

DISTURBANCE_KINDS: tuple[str, ...] = ("drift", "load")
LOAD_SPAN = 4.0
"""The load step falls within the first ``LOAD_SPAN`` time scales ``T`` of an experiment (the fixed
procedure's experiments run 3 to 9 ``T``)."""


@dataclass(frozen=True)
class Disturbances:
    """Levels of the disturbances of every experiment (module docstring); 0 is none.

    Attributes
    ----------
    drift : float
        Standard deviation of the random walk after one ``T``, output units (>= 0).
    load : float
        Steady output change of the load step (its rate per ``T`` for an integrating plant), >= 0.
    """

    drift: float = 0.0
    load: float = 0.0

    def __post_init__(self) -> None:
        for kind in DISTURBANCE_KINDS:
            object.__setattr__(self, kind, require_number(getattr(self, kind), f"disturbances[{kind!r}]", nonnegative=True))

    @classmethod
    def from_argument(cls, value: Any, name: str = "disturbances") -> Disturbances:
        """From ``None`` (none), a ``Disturbances`` or a mapping ``{kind: level}``; one ``ValueError``
        naming ``name`` (the environment argument) for anything else, an unknown kind or a bad level."""
        if value is None:
            return cls()
        if isinstance(value, cls):
            return value
        if not isinstance(value, Mapping):
            raise ValueError(f"{name} must be a mapping of kind to level, e.g. {{'drift': 0.02}}, got {value!r}")
        unknown = sorted(str(k) for k in value if k not in DISTURBANCE_KINDS)
        if unknown:
            raise ValueError(f"{name}: unknown kind {unknown[0]!r}; valid kinds: {', '.join(DISTURBANCE_KINDS)}")
        levels = {}
        for kind, level in value.items():
            levels[kind] = require_number(level, f"{name}[{kind!r}]", nonnegative=True)
        return cls(**levels)

    @property
    def active(self) -> bool:
        return self.drift > 0.0 or self.load > 0.0

    def to_dict(self) -> dict[str, float]:
        """The non-zero levels by kind."""
        return {kind: getattr(self, kind) for kind in DISTURBANCE_KINDS if getattr(self, kind) > 0.0}


class DisturbedNoise(MeasurementNoise):
    """White noise plus the disturbances of one experiment, drawn as the run grows.

    Wraps the experiment's :class:`~envs.identification.noise.MeasurementNoise` ``white``
    (whose samples it adds unchanged) with the same interface (``first``, ``size``,
    ``drawn_as_needed``, ``noise_std``).

    Parameters
    ----------
    white : MeasurementNoise
        The experiment's white noise.
    seed : ndarray
        The seed of ``white``'s child stream (the disturbances' streams are spawned from it).
    disturbances : Disturbances
    plant : Plant
        The true plant (the load's response).
    dt, scale : float
        Sample time and time scale ``T``.
    """

    def __init__(self, white: MeasurementNoise, seed: np.ndarray, disturbances: Disturbances, plant, dt: float,
                 scale: float) -> None:  # fmt: skip
        super().__init__(white.noise_std, white.size, None)
        self.white = white
        self._drift_step = disturbances.drift * math.sqrt(dt / scale)
        self._drift_source = _stream(seed, 1) if disturbances.drift > 0 else None
        self._drift_level = 0.0
        self._load = None
        self.load_start, self.load_input = None, 0.0  # the load's first sample and its input step
        if disturbances.load > 0:
            self.load_start, self.load_input, self._load = _load_response(
                _stream(seed, 2), disturbances.load, plant, dt, scale, self.size
            )

    @property
    def drawn_as_needed(self) -> bool:
        return self._drawn < self.size

    def _fill(self, fresh: np.ndarray, drawn: int, count: int) -> None:
        """The white samples, plus the drift's walk and the load's response over them."""
        fresh[:] = self.white.first(count)[drawn:]
        if self._drift_source is not None:
            walk = self._drift_level + self._drift_step * np.cumsum(self._drift_source.standard_normal(count - drawn))
            self._drift_level = float(walk[-1])
            fresh += walk
        if self._load is not None:
            fresh += self._load.response(count)[drawn:]


def _stream(seed: np.ndarray, key: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(s) for s in seed], spawn_key=(key,))))


def _load_response(source: np.random.Generator, level: float, plant, dt: float, scale: float, size: int):
    """``(first sample, input step, the plant's response to it)``, the response an
    :class:`~envs.simulation.open_loop.OpenLoopRun` (exact for the held step)."""
    from envs.simulation.open_loop import OpenLoopRun

    span = min(LOAD_SPAN * scale, size * dt)
    start = min(int(source.uniform(0.0, span) / dt), size - 1)
    sign = 1.0 if source.uniform() < 0.5 else -1.0
    height = level / (abs(plant.gain) * (scale if plant.integrating else 1.0)) * math.copysign(1.0, plant.gain) * sign
    inputs = np.zeros(size)
    inputs[start:] = height
    return start, height, OpenLoopRun(plant.state_space(), plant.dead_time, inputs, dt)
