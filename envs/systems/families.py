"""Seeded families of plants ``K G(s) e^{-L s}``, random and fixed.

A random plant is drawn in three independent steps, so that what varies meaningfully is the shape:

1. a *shape*: a unit-gain rational ``G0(s)`` chosen uniformly from the family's ``shapes``, with
   its parameters drawn uniformly from :class:`~envs.systems.shapes.ShapeRanges` (the shapes
   are :mod:`envs.systems.shapes`);
2. a *dead-time fraction* ``f = L / T_ar`` uniform over ``dead_time_fraction`` (for ``fopdt`` this
   is the normalized dead time ``tau = L / (L + T)`` of Gorez-Klan section 2);
3. a *scale*: the average residence time ``T_ar`` (Gorez-Klan eq. 2-5; for an integrating plant
   the ``L_n`` of the dynamics additional to the integrator, Ingimundarson section 2.1)
   log-uniform over ``residence_time``, and the gain ``K`` with magnitude log-uniform over
   ``gain`` and sign negative with probability ``negative_gain_probability``.

The delay-free part is ``G0`` with time stretched so that its own residence time is
``(1 - f) T_ar``, and ``L = f T_ar``.  Integrating plants are ``K G0(s) e^{-Ls} / s``: ``G0`` is
the ``1/Q(s)`` of ``K e^{-Ls}/(s Q(s))`` (:class:`IntegratingConfig`) and ``K`` the velocity gain.

The ``stable`` family is the mixture of the three self-regulating families: each plant comes from
``fopdt``, ``sopdt`` or ``lag-chain`` with equal probability (:class:`MixtureConfig`); it is the
default of the environments on self-regulating plants.  The ``benchmark`` family draws uniformly
from the fixed batches of :func:`~envs.systems.benchmark_batches.benchmark_plants`, unscaled.  Every
sampler takes a ``numpy.random.Generator`` and draws from nothing else.

References
----------
.. [1] R. Gorez, P. Klan, "Simple models for process control", section 4, eq. 4-15, 4-16.
.. [2] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, section 4.4 (Table 1) and section 5.3 (Table 2).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from envs.systems.benchmark_batches import _KINDS, _benchmark_batch
from envs.systems.coefficients import shape_residence_time
from envs.systems.plants import Plant
from envs.systems.shapes import _SHAPES, SHAPES, ShapeRanges, _check_interval, _positive

__all__ = [
    "FAMILIES",
    "RandomFamilyConfig",
    "FopdtConfig",
    "SopdtConfig",
    "LagChainConfig",
    "IntegratingConfig",
    "BenchmarkConfig",
    "MixtureConfig",
    "check_family_config",
    "sample_plant",
    "sample_plants",
]


FAMILIES: tuple[str, ...] = ("fopdt", "sopdt", "lag-chain", "integrating", "benchmark", "stable")


# --------------------------------------------------------------------------- configs
@dataclass(frozen=True)
class RandomFamilyConfig:
    """Distributions shared by the random families (see the module docstring for the recipe).

    Attributes
    ----------
    gain : (float, float)
        Range of ``|K|`` (velocity gain ``K_v`` if integrating), log-uniform, ``0 < low``.
        Default ``(0.1, 10.0)``.
    negative_gain_probability : float
        Probability that ``K < 0``.  Default ``0.5``.
    residence_time : (float, float)
        Range of ``T_ar`` (``L_n`` if integrating), log-uniform, ``0 < low``.  Default
        ``(0.1, 100.0)``.
    dead_time_fraction : (float, float)
        Range of ``f = L / T_ar``, uniform, ``0 <= low, 0 < high < 1``.
    shapes : tuple of str
        Shapes drawn uniformly; a subset of the family's ``allowed_shapes``.
    shape_ranges : ShapeRanges
        Ranges of the shape parameters.
    """

    allowed_shapes: ClassVar[tuple[str, ...]] = SHAPES
    integrating: ClassVar[bool] = False

    gain: tuple[float, float] = (0.1, 10.0)
    negative_gain_probability: float = 0.5
    residence_time: tuple[float, float] = (0.1, 100.0)
    dead_time_fraction: tuple[float, float] = (0.05, 0.95)
    shapes: tuple[str, ...] = SHAPES
    shape_ranges: ShapeRanges = field(default_factory=ShapeRanges)

    def __post_init__(self) -> None:
        _positive("gain", self.gain)
        _positive("residence_time", self.residence_time)
        _check_interval(
            "dead_time_fraction", self.dead_time_fraction, lambda low, high: 0 <= low and 0 < high < 1,
            "0 <= low, 0 < high < 1 (a family of plants without dead time has no dead time to design from)"
        )
        if not 0.0 <= self.negative_gain_probability <= 1.0:
            raise ValueError(f"negative_gain_probability must be in [0, 1], got {self.negative_gain_probability!r}")
        unknown = [s for s in self.shapes if s not in self.allowed_shapes]
        if not self.shapes or unknown:
            raise ValueError(
                f"shapes must be a non-empty subset of {', '.join(self.allowed_shapes)}; got {self.shapes!r}"
            )
        if not isinstance(self.shape_ranges, ShapeRanges):
            raise ValueError(f"shape_ranges must be a ShapeRanges, got {type(self.shape_ranges).__name__}")


@dataclass(frozen=True)
class FopdtConfig(RandomFamilyConfig):
    """``fopdt``: ``K e^{-Ls}/(Ts+1)``.

    ``dead_time_fraction`` is the normalized dead time ``tau = L/(L+T)``, uniform over
    ``(0.05, 0.95)``; ``T_ar = L + T`` log-uniform over ``(0.1, 100)``; ``|K|`` log-uniform over
    ``(0.1, 10)``, either sign with probability 1/2.  Only the ``lag`` shape is allowed.
    """

    allowed_shapes: ClassVar[tuple[str, ...]] = ("lag",)
    shapes: tuple[str, ...] = ("lag",)


@dataclass(frozen=True)
class SopdtConfig(RandomFamilyConfig):
    """``sopdt``: ``K e^{-Ls}/((T1 s+1)(T2 s+1))`` or ``K e^{-Ls}/(T^2 s^2 + 2 zeta T s + 1)``.

    Shapes ``two-lags`` (``T2/T1`` uniform over ``(0.05, 1)``) and ``underdamped`` (``zeta``
    uniform over ``(0.4, 1)``), each with probability 1/2; ``L/T_ar`` uniform over
    ``(0.05, 0.95)``; ``T_ar``, ``K`` as for :class:`FopdtConfig`.
    """

    allowed_shapes: ClassVar[tuple[str, ...]] = ("two-lags", "underdamped")
    shapes: tuple[str, ...] = ("two-lags", "underdamped")


@dataclass(frozen=True)
class LagChainConfig(RandomFamilyConfig):
    """``lag-chain``: higher-order and non-minimum-phase shapes of the papers' test batches.

    Shapes ``lag-n``, ``geometric``, ``nmp``, ``resonant``, ``parallel`` (module docstring),
    each with probability 1/5; ``L/T_ar`` uniform over ``(0.0, 0.8)`` (these shapes already carry
    an apparent dead time); ``T_ar``, ``K`` as for :class:`FopdtConfig`.
    """

    allowed_shapes: ClassVar[tuple[str, ...]] = ("lag-n", "geometric", "nmp", "resonant", "parallel")
    shapes: tuple[str, ...] = ("lag-n", "geometric", "nmp", "resonant", "parallel")
    dead_time_fraction: tuple[float, float] = (0.0, 0.8)


@dataclass(frozen=True)
class IntegratingConfig(RandomFamilyConfig):
    """``integrating``: ``K e^{-Ls}/(s Q(s))`` with ``1/Q`` any stable shape.

    All eight shapes, each with probability 1/8; ``K`` is the velocity gain (units 1/time),
    ``|K|`` log-uniform over ``(0.1, 10)``, either sign with probability 1/2; ``L_n`` (``T_ar``
    of ``e^{-Ls}/Q(s)``) log-uniform over ``(0.1, 100)``; ``L/L_n`` uniform over ``(0.05, 0.9)``
    (Ingimundarson's batch spans 0.45 .. 0.83).
    """

    integrating: ClassVar[bool] = True
    dead_time_fraction: tuple[float, float] = (0.05, 0.9)


@dataclass(frozen=True)
class BenchmarkConfig:
    """``benchmark``: a plant drawn uniformly from ``benchmark_plants(kind)``, unscaled.

    Attributes
    ----------
    kind : {"stable", "integrating", "all"}
        Default ``"all"``.
    """

    kind: str = "all"

    def __post_init__(self) -> None:
        if self.kind not in _KINDS:
            raise ValueError(f"kind must be one of {', '.join(_KINDS)}; got {self.kind!r}")


@dataclass(frozen=True)
class MixtureConfig:
    """``stable``: each plant from one of ``families`` (equal probability), with that family's config.

    Attributes
    ----------
    fopdt, sopdt, lag_chain : family configs
        The configs of the three self-regulating families (their defaults by default).
    """

    fopdt: FopdtConfig = field(default_factory=FopdtConfig)
    sopdt: SopdtConfig = field(default_factory=SopdtConfig)
    lag_chain: LagChainConfig = field(default_factory=LagChainConfig)

    def members(self) -> tuple[RandomFamilyConfig, ...]:
        return (self.fopdt, self.sopdt, self.lag_chain)
_CONFIGS: dict[str, type] = {
    "stable": MixtureConfig,
    "fopdt": FopdtConfig,
    "sopdt": SopdtConfig,
    "lag-chain": LagChainConfig,
    "integrating": IntegratingConfig,
    "benchmark": BenchmarkConfig,
}


_DEFAULT_CONFIGS: dict[str, object] = {}


# --------------------------------------------------------------------------- samplers
def _config_for(family: str, config: object) -> object:
    if family not in _CONFIGS:
        raise ValueError(f"unknown plant family {family!r}; valid families: {', '.join(FAMILIES)}")
    expected = _CONFIGS[family]
    if config is None:  # the configs are frozen: the default of each family is built once
        if family not in _DEFAULT_CONFIGS:
            _DEFAULT_CONFIGS[family] = expected()
        return _DEFAULT_CONFIGS[family]
    if type(config) is not expected:
        raise TypeError(f"config for family {family!r} must be a {expected.__name__}, got {type(config).__name__}")
    return config


def _log_uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(np.exp(rng.uniform(np.log(bounds[0]), np.log(bounds[1]))))


def _time_scaled(coefficients: np.ndarray, scale: float) -> np.ndarray:
    """Coefficients of ``p(scale s)``, descending powers."""
    return np.asarray(coefficients, dtype=float) * scale ** np.arange(len(coefficients))[::-1]


def _sample_random(rng: np.random.Generator, config: RandomFamilyConfig) -> Plant:
    shape = config.shapes[rng.integers(len(config.shapes))]
    num, den = _SHAPES[shape](rng, config.shape_ranges)
    fraction = rng.uniform(*config.dead_time_fraction)
    residence_time = _log_uniform(rng, config.residence_time)
    sign = -1.0 if rng.random() < config.negative_gain_probability else 1.0
    gain = sign * _log_uniform(rng, config.gain)
    scale = (1.0 - fraction) * residence_time / shape_residence_time(tuple(num), tuple(den))  # the plant below is validated
    num, den = gain * _time_scaled(num, scale), _time_scaled(den, scale)
    if config.integrating:
        den = np.convolve(den, [1.0, 0.0])
    return Plant(tuple(num), tuple(den), fraction * residence_time)


def sample_plant(family: str, rng: np.random.Generator, config: object = None) -> Plant:
    """Draw one plant of a family.

    Parameters
    ----------
    family : str
        One of :data:`FAMILIES`.
    rng : numpy.random.Generator
        The only source of randomness.
    config : family config, optional
        A :class:`FopdtConfig`, :class:`SopdtConfig`, :class:`LagChainConfig`,
        :class:`IntegratingConfig`, :class:`BenchmarkConfig` or :class:`MixtureConfig` matching ``family``; defaults to
        that class's defaults.

    Returns
    -------
    Plant
        A validated plant, stable or with one integrator.

    Raises
    ------
    ValueError
        If ``family`` is unknown (the message lists the valid ones).
    TypeError
        If ``config`` is not the config class of ``family``.

    Examples
    --------
    >>> plant = sample_plant("fopdt", np.random.default_rng(0))
    >>> plant.order, 0.05 <= plant.dead_time / plant.residence_time <= 0.95
    (1, True)
    """
    config = _config_for(family, config)
    if isinstance(config, BenchmarkConfig):
        plants = _benchmark_batch(config.kind)
        return plants[rng.integers(len(plants))]
    if isinstance(config, MixtureConfig):
        members = config.members()
        return _sample_random(rng, members[rng.integers(len(members))])
    return _sample_random(rng, config)


def check_family_config(family: str, config: object, name: str = "family_config") -> object:
    """``config`` if it is None or the config class of ``family`` (:func:`sample_plant`), else a
    ``ValueError`` naming ``name``: ``"family_config must be a FopdtConfig for family 'fopdt', got int"``."""
    if config is None:
        return None
    try:
        return _config_for(family, config)
    except TypeError:
        expected = _CONFIGS[family].__name__
        raise ValueError(f"{name} must be a {expected} for family {family!r}, got {type(config).__name__}") from None


def sample_plants(family: str, n: int, seed: int, config: object = None) -> list[Plant]:
    """``n`` plants of ``family`` from ``numpy.random.default_rng(seed)``; see :func:`sample_plant`."""
    for name, value in (("n", n), ("seed", seed)):
        if not isinstance(value, int | np.integer) or isinstance(value, bool) or value < 0:
            raise ValueError(f"{name} must be an integer >= 0, got {value!r}")
    rng = np.random.default_rng(seed)
    return [sample_plant(family, rng, config) for _ in range(n)]
