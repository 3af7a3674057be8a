"""Seeded families of plants ``K G(s) e^{-L s}``, random and fixed.

A random plant is drawn in three independent steps, so that what varies meaningfully is the shape:

1. a *shape*: a unit-gain rational ``G0(s)`` chosen uniformly from the family's ``shapes``, with
   its parameters drawn uniformly from :class:`ShapeRanges` (table below);
2. a *dead-time fraction* ``f = L / T_ar`` uniform over ``dead_time_fraction`` (for ``fopdt`` this
   is the normalized dead time ``tau = L / (L + T)`` of Gorez-Klan section 2);
3. a *scale*: the average residence time ``T_ar`` (Gorez-Klan eq. 2-5; for an integrating plant
   the ``L_n`` of the dynamics additional to the integrator, Ingimundarson section 2.1)
   log-uniform over ``residence_time``, and the gain ``K`` with magnitude log-uniform over
   ``gain`` and sign negative with probability ``negative_gain_probability``.

The delay-free part is ``G0`` with time stretched so that its own residence time is
``(1 - f) T_ar``, and ``L = f T_ar``.  Integrating plants are ``K G0(s) e^{-Ls} / s``: ``G0`` is
the ``1/Q(s)`` of ``K e^{-Ls}/(s Q(s))`` (:class:`IntegratingConfig`) and ``K`` the velocity gain.

=============  ======================================================  ===========================
shape          ``G0(s)``                                               parameters (uniform)
=============  ======================================================  ===========================
lag            ``1/(s+1)``                                             --
two-lags       ``1/((s+1)(r s+1))``                                    ``r``: time_constant_ratio
underdamped    ``1/(s^2 + 2 zeta s + 1)``                              ``zeta``: damping
lag-n          ``1/(s+1)^n``                                           ``n``: lag_orders (integers)
geometric      ``1/((1+s)(1+as)(1+a^2 s)(1+a^3 s))``                   ``a``: geometric_ratio
nmp            ``(1-as)/(s+1)^m``                                      ``a``: zero_time_constant,
                                                                       ``m``: one of nmp_orders
resonant       ``1/((s+1)(s^2/w^2 + 2 zeta s/w + 1))`` (Ingimundarson  ``w``: resonant_frequency,
               P5: ``w = 3``, ``zeta = 1/3``)                          ``zeta``: resonant_damping
parallel       ``(1-c)/(s+1) + c/(Ts+1)`` (Ingimundarson P6:           ``c``: slow_weight,
               ``c = 0.5``, ``T = 10``)                                ``T``: slow_time_constant
=============  ======================================================  ===========================

Ingimundarson's P7 ``64/((s+1)(s+2)(s+4)(s+8))`` is the geometric shape with ``a = 1/2``.

The ``stable`` family is the mixture of the three self-regulating families: each plant comes from
``fopdt``, ``sopdt`` or ``lag-chain`` with equal probability (:class:`MixtureConfig`); it is the
default of the environments on self-regulating plants.  The ``benchmark`` family draws uniformly from the fixed batches of :func:`benchmark_plants`,
unscaled.  Every sampler takes a ``numpy.random.Generator`` and draws from nothing else.

References
----------
.. [1] R. Gorez, P. Klan, "Simple models for process control", section 4, eq. 4-15, 4-16.
.. [2] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, section 4.4 (Table 1) and section 5.3 (Table 2).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, ClassVar

import numpy as np

from envs.systems.plants import Plant
from envs.systems.coefficients import shape_residence_time

__all__ = [
    "FAMILIES",
    "SHAPES",
    "ShapeRanges",
    "RandomFamilyConfig",
    "FopdtConfig",
    "SopdtConfig",
    "LagChainConfig",
    "IntegratingConfig",
    "BenchmarkConfig",
    "MixtureConfig",
    "benchmark_plants",
    "check_family_config",
    "sample_plant",
    "sample_plants",
]

FAMILIES: tuple[str, ...] = ("fopdt", "sopdt", "lag-chain", "integrating", "benchmark", "stable")


def _check_interval(name: str, value: object, condition: Callable[[float, float], bool], requirement: str) -> None:
    try:
        low, high = (float(v) for v in value)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (low, high), got {value!r}") from None
    if not (np.isfinite(low) and np.isfinite(high) and low <= high and condition(low, high)):
        raise ValueError(f"{name} must be (low, high) with low <= high and {requirement}, got {value!r}")


def _positive(name: str, value: object) -> None:
    _check_interval(name, value, lambda low, high: low > 0, "0 < low")


# --------------------------------------------------------------------------- shapes
@dataclass(frozen=True)
class ShapeRanges:
    """Ranges of the normalized shape parameters; each is drawn uniformly from its range.

    Attributes
    ----------
    time_constant_ratio : (float, float)
        ``r = T2/T1`` of ``two-lags``, in ``(0, 1]``.  Default ``(0.05, 1.0)``.
    damping : (float, float)
        ``zeta`` of ``underdamped``, ``> 0``.  Default ``(0.4, 1.0)``.
    lag_orders : (int, int)
        Inclusive range of ``n`` of ``lag-n``, ``>= 1``.  Default ``(2, 10)`` (Gorez-Klan P2: 10).
    geometric_ratio : (float, float)
        ``a`` of ``geometric``, in ``(0, 1]``.  Default ``(0.2, 0.9)`` (Gorez-Klan P1: 0.4).
    zero_time_constant : (float, float)
        ``a`` of the right-half-plane zero ``(1 - a s)`` of ``nmp``, ``> 0``.  Default
        ``(0.1, 2.0)`` (Ingimundarson P3: 1, P4: 2).
    nmp_orders : tuple of int
        Orders ``m`` of ``nmp``, one drawn uniformly.  Default ``(3, 5)``.
    resonant_frequency, resonant_damping : (float, float)
        ``w`` (relative to the real pole) and ``zeta`` of ``resonant``.  Defaults ``(1.5, 5.0)``
        and ``(0.2, 0.7)`` (Ingimundarson P5: 3, 1/3).
    slow_weight, slow_time_constant : (float, float)
        ``c`` in ``[0, 1]`` and ``T > 0`` of ``parallel``.  Defaults ``(0.2, 0.8)`` and
        ``(3.0, 30.0)`` (Ingimundarson P6: 0.5, 10).
    """

    time_constant_ratio: tuple[float, float] = (0.05, 1.0)
    damping: tuple[float, float] = (0.4, 1.0)
    lag_orders: tuple[int, int] = (2, 10)
    geometric_ratio: tuple[float, float] = (0.2, 0.9)
    zero_time_constant: tuple[float, float] = (0.1, 2.0)
    nmp_orders: tuple[int, ...] = (3, 5)
    resonant_frequency: tuple[float, float] = (1.5, 5.0)
    resonant_damping: tuple[float, float] = (0.2, 0.7)
    slow_weight: tuple[float, float] = (0.2, 0.8)
    slow_time_constant: tuple[float, float] = (3.0, 30.0)

    def __post_init__(self) -> None:
        for name in ("damping", "zero_time_constant", "resonant_frequency", "resonant_damping", "slow_time_constant"):
            _positive(name, getattr(self, name))
        for name in ("time_constant_ratio", "geometric_ratio"):
            _check_interval(name, getattr(self, name), lambda low, high: 0 < low and high <= 1, "0 < low, high <= 1")
        _check_interval("slow_weight", self.slow_weight, lambda lo, hi: lo >= 0 and hi <= 1, "0 <= low, high <= 1")
        _check_interval(
            "lag_orders", self.lag_orders, lambda low, high: low >= 1 and low == int(low) and high == int(high),
            "integers >= 1",
        )
        if not self.nmp_orders or any(int(m) != m or m < 1 for m in self.nmp_orders):
            raise ValueError(f"nmp_orders must be a non-empty tuple of integers >= 1, got {self.nmp_orders!r}")


def _lags(*time_constants: float) -> np.ndarray:
    den = np.array([1.0])
    for t in time_constants:
        den = np.convolve(den, [t, 1.0])  # numpy.polymul of polynomials without leading zeros
    return den


def _underdamped(rng: np.random.Generator, r: ShapeRanges) -> tuple[np.ndarray, np.ndarray]:
    return np.array([1.0]), np.array([1.0, 2.0 * rng.uniform(*r.damping), 1.0])


def _nmp(rng: np.random.Generator, r: ShapeRanges) -> tuple[np.ndarray, np.ndarray]:
    a = rng.uniform(*r.zero_time_constant)
    order = int(r.nmp_orders[rng.integers(len(r.nmp_orders))])
    return np.array([-a, 1.0]), _lags(*[1.0] * order)


def _resonant(rng: np.random.Generator, r: ShapeRanges) -> tuple[np.ndarray, np.ndarray]:
    w, zeta = rng.uniform(*r.resonant_frequency), rng.uniform(*r.resonant_damping)
    return np.array([1.0]), np.convolve([1.0, 1.0], [1.0 / w**2, 2.0 * zeta / w, 1.0])


def _parallel(rng: np.random.Generator, r: ShapeRanges) -> tuple[np.ndarray, np.ndarray]:
    c, t = rng.uniform(*r.slow_weight), rng.uniform(*r.slow_time_constant)
    return np.array([(1.0 - c) * t + c, 1.0]), _lags(1.0, t)  # (1-c)/(s+1) + c/(ts+1)


# Each shape draws its parameters and returns a unit-static-gain (num, den), descending powers.
_SHAPES: dict[str, Callable[[np.random.Generator, ShapeRanges], tuple[np.ndarray, np.ndarray]]] = {
    "lag": lambda rng, r: (np.array([1.0]), _lags(1.0)),
    "two-lags": lambda rng, r: (np.array([1.0]), _lags(1.0, rng.uniform(*r.time_constant_ratio))),
    "underdamped": _underdamped,
    "lag-n": lambda rng, r: (np.array([1.0]), _lags(*[1.0] * int(rng.integers(*r.lag_orders, endpoint=True)))),
    "geometric": lambda rng, r: (np.array([1.0]), _lags(*(rng.uniform(*r.geometric_ratio) ** np.arange(4)))),
    "nmp": _nmp,
    "resonant": _resonant,
    "parallel": _parallel,
}
SHAPES: tuple[str, ...] = tuple(_SHAPES)


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
        Range of ``f = L / T_ar``, uniform, ``0 <= low, high < 1``.
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
            "dead_time_fraction", self.dead_time_fraction, lambda low, high: 0 <= low and high < 1, "0 <= low, high < 1"
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


_KINDS = ("stable", "integrating", "all")
_CONFIGS: dict[str, type] = {
    "stable": MixtureConfig,
    "fopdt": FopdtConfig,
    "sopdt": SopdtConfig,
    "lag-chain": LagChainConfig,
    "integrating": IntegratingConfig,
    "benchmark": BenchmarkConfig,
}


_DEFAULT_CONFIGS: dict[str, object] = {}


# --------------------------------------------------------------------------- benchmark batches
def benchmark_plants(kind: str = "all") -> dict[str, Plant]:
    """The fixed test batches of the papers, by name.

    Parameters
    ----------
    kind : {"stable", "integrating", "all"}
        ``"stable"``: Gorez-Klan P1, P2 and Ingimundarson's seven stable processes;
        ``"integrating"``: Ingimundarson's eight integrating processes; ``"all"``: both.

    Returns
    -------
    dict of str to Plant
        Names ``gorez-klan-P1``, ``gorez-klan-P2``, ``ingimundarson-stable-P1`` ..
        ``-P7``, ``ingimundarson-integrating-P1`` .. ``-P8``, in that order.

    Raises
    ------
    ValueError
        If ``kind`` is not one of the three.

    References
    ----------
    Gorez-Klan eq. 4-15 (``alpha = 0.4``) and 4-16 (``n = 10``), both with ``T_ar = 1`` and no
    dead time.  Ingimundarson section 4.4, ``P_i(s) e^{-5s}``, and section 5.3,
    ``P_i(s) e^{-5s}/s``.

    Examples
    --------
    >>> round(benchmark_plants("stable")["ingimundarson-stable-P1"].residence_time, 9)
    17.0
    """
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {', '.join(_KINDS)}; got {kind!r}")
    lags = Plant.from_time_constants
    plants: dict[str, Plant] = {}
    if kind in ("stable", "all"):
        a = 0.4
        t = 1.0 / (1.0 + a + a**2 + a**3)  # T_ar = T (1 + a + a^2 + a^3) = 1
        plants["gorez-klan-P1"] = lags(1.0, [t * a**k for k in range(4)])
        plants["gorez-klan-P2"] = lags(1.0, [0.1] * 10)  # T_ar = 10 T = 1
        for i, (num, den) in enumerate(_ingimundarson_stable(), start=1):
            plants[f"ingimundarson-stable-P{i}"] = Plant(tuple(num), tuple(den), 5.0)
    if kind in ("integrating", "all"):
        for i, (num, den) in enumerate(_ingimundarson_integrating(), start=1):
            plants[f"ingimundarson-integrating-P{i}"] = Plant(tuple(num), tuple(np.polymul(den, [1.0, 0.0])), 5.0)
    return plants


def _benchmark_batch(kind: str) -> tuple[Plant, ...]:
    """``benchmark_plants(kind)`` as a tuple, built once (the plants are immutable)."""
    if kind not in _BENCHMARK_BATCHES:
        _BENCHMARK_BATCHES[kind] = tuple(benchmark_plants(kind).values())
    return _BENCHMARK_BATCHES[kind]


_BENCHMARK_BATCHES: dict[str, tuple[Plant, ...]] = {}


def _ingimundarson_stable() -> list[tuple[np.ndarray, np.ndarray]]:
    """``P_1 .. P_7`` of section 4.4 as ``(num, den)``."""
    return [
        (np.array([1.0]), _lags(10.0, 2.0)),  # 1/((10s+1)(2s+1))
        (np.array([1.0]), _lags(1.0, 1.0, 1.0)),  # 1/(s+1)^3
        (np.array([-1.0, 1.0]), _lags(*[1.0] * 5)),  # (-s+1)/(s+1)^5
        (np.array([-2.0, 1.0]), _lags(1.0, 1.0, 1.0)),  # (-2s+1)/(s+1)^3
        (np.array([9.0]), np.polymul([1.0, 1.0], [1.0, 2.0, 9.0])),  # 9/((s+1)(s^2+2s+9))
        (np.array([0.55, 0.1]), np.polymul([1.0, 1.0], [1.0, 0.1])),  # 0.5/(s+1) + 0.05/(s+0.1)
        (np.array([64.0]), np.poly([-1.0, -2.0, -4.0, -8.0])),  # 64/((s+1)(s+2)(s+4)(s+8))
    ]


def _ingimundarson_integrating() -> list[tuple[np.ndarray, np.ndarray]]:
    """``P_1 .. P_8`` of section 5.3 (the dynamics additional to ``1/s``) as ``(num, den)``."""
    stable = _ingimundarson_stable()
    return [
        (np.array([1.0]), _lags(1.0)),  # 1/(s+1)
        (np.array([1.0]), _lags(0.1, 1.0)),  # 1/((0.1s+1)(s+1))
        *stable[1:4],  # 1/(s+1)^3, (-s+1)/(s+1)^5, (-2s+1)/(s+1)^3
        (np.array([1.0]), np.polymul([1.0, 1.0], [1.0, 2.0, 9.0])),  # 1/((s+1)(s^2+2s+9)), gain 1/9
        *stable[5:],  # 0.5/(s+1) + 0.05/(s+0.1), 64/((s+1)(s+2)(s+4)(s+8))
    ]


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
