"""The learned rule: a regression from the observation to the oracle's action, with a safety margin.

A supervised baseline: on training plants, the oracle (:func:`baselines.oracle.oracle`)
gives the best design parameter of each identified plant; a regression learns it from the
observation an agent sees, in the agent's own action coordinate.  The oracle's parameter sits on the
edge of the feasible set (often on the ``Ms <= 2`` cliff), so a regression that is right on average
violates the constraints on about half of the plants; the rule therefore adds a *margin* (constant,
or scaled per plant: section "Margin scales") to the predicted action, towards the conservative side
(larger ``mu`` or ``T_r``), chosen with the
regression on validation plants to minimize their mean cost (:func:`select`), optionally among the
margins whose violation rate is certified below a target (section "Certified margins").  If the
learned rule matches the agents, reinforcement learning was not needed.

This module is the numerics only (numpy and scikit-learn): the regressions (:data:`MODEL_KINDS`,
:func:`fit_regression`), the rule (:class:`LearnedRule`) and the choice of model and margin given
a validation cost (:func:`select`).  Playing the environment to build the data and to score a rule
is ``agents.training.learned_rule``'s.

Model kinds
-----------
``ridge-quadratic``
    Ridge regression on the standardized observation and its pairwise products and squares
    (Hoerl and Kennard, Technometrics 12, 1970; Hastie, Tibshirani and Friedman, *The Elements of
    Statistical Learning*, 2nd ed., 2009, section 3.4.1), the penalty chosen by leave-one-out
    cross-validation on the training plants (``RidgeCV``).
``boosting``
    Gradient-boosted regression trees on the squared error (Friedman, Ann. Statist. 29, 2001;
    scikit-learn's histogram-based ``HistGradientBoostingRegressor``), a fixed number of trees
    (no early stopping, so no random split of the training plants).
``quantile-boosting``
    The same trees on the pinball loss of the :data:`QUANTILE` quantile (Koenker and Bassett,
    Econometrica 46, 1978): an estimate of the action below which the oracle's lies on that share
    of the plants like this one, i.e. a conservative fit before any margin, more conservative where
    the oracle's action is harder to predict.  On the three fixed-mode environments it needs a
    smaller margin and costs less than ``boosting`` with its best margin.

Margin scales
-------------
The margin is added as it is (``margin_scale="constant"``), or scaled per plant by the width of the
quantile band of the oracle's action (``"spread"``): the ``q`` and ``1 - q`` quantile trees
(:data:`QUANTILE` by default) give ``w(x) = max(|q_hi(x) - q_lo(x)|, SPREAD_FLOOR)``, divided by its
mean over the training plants, so that the margin is ``margin * w(x) / mean(w)`` (:class:`Spread`): large
where the oracle's action is hard to predict from the observation, small where it is not.  This is the
scaling of conformalized quantile regression (Romano, Patterson and Candes, "Conformalized Quantile
Regression", NeurIPS 2019), whose correction moves each band end by a calibrated multiple; here the
multiple is the margin, chosen on the validation plants as the constant one is (and certified the
same way: the certificate is about the rule as a whole, whatever its shape).  Where the violations of
the unshifted rule gather on plants of wide bands, the scaled margin reaches a violation count at a
lower mean cost than a constant one.

Certified margins
-----------------
The margin of least validation cost lets a few validation plants violate when that is cheaper on
average.  Given a target violation rate ``alpha`` and a confidence ``1 - delta``, :func:`select`
chooses only among the margins whose violation rate on new plants is at most ``alpha`` with
probability at least ``1 - delta`` over the draw of the validation plants: the *Learn then Test*
calibration (Angelopoulos, Bates, Candes, Jordan and Lei, "Learn then Test: Calibrating Predictive
Algorithms to Achieve Risk Control", arXiv:2110.01052, 2021; the same calibration is MAPIE's
``risk_control`` with a fixed-sequence FWER method).  Each candidate
``(kind, margin)`` is a null hypothesis "its violation rate exceeds ``alpha``", tested with the exact
binomial p-value of its ``k`` violations on ``n`` validation plants, ``P(Binomial(n, alpha) <= k)``
(the p-value of a 0/1 loss; rejecting at level ``delta`` is the same as the one-sided
Clopper-Pearson upper bound ``violation_bound(k, n, 1 - delta) <= alpha``).  Per kind the margins are
tested from the largest down, stopping at the first that fails (fixed-sequence testing, Bauer,
Stat. Med. 10, 1991; it needs no ordering of the violation rates to be valid), at level ``delta / K`` for ``K`` kinds (Bonferroni): every margin certified so
is then below the target simultaneously, so choosing among them by validation cost keeps the
promise.  The promise is about the environment's plant distribution and noise, from which the
validation plants are exchangeable draws, not about any single plant.  When no candidate is
certified (too few validation plants for the target: with ``k = 0`` the bound is
``1 - delta**(1/n)``, so ``alpha = 1%`` at 95% needs ``n >= 299`` for one kind), :func:`select`
returns the candidate of fewest violations (then least cost) and says that it is uncertified.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["MARGIN_SCALES", "MODEL_KINDS", "QUANTILE", "SPREAD_FLOOR", "LearnedRule", "Selection", "Spread", "Validated",
           "fit_regression", "fit_spread", "kind_confidence", "select", "violation_bound"]

MODEL_KINDS: tuple[str, ...] = ("ridge-quadratic", "boosting", "quantile-boosting")
"""The regressions of :func:`fit_regression` (module docstring, "Model kinds")."""

QUANTILE = 0.9
"""The quantile of the oracle's action that ``quantile-boosting`` estimates.  Chosen among 0.75, 0.85,
0.9, 0.95 and 0.98 by the mean cost at the best margin, on the validation plants and by 5-fold
cross-validation on 1000 training plants, in each of ``PID-v0``, ``FPPI-v0`` and ``MSP-v0``
(seed 0): 0.9 and 0.95 were best or within 0.1 of the best everywhere, 0.75 and 0.98 worse; 0.9
is the less extreme estimate of the two."""

MARGIN_SCALES: tuple[str, ...] = ("constant", "spread")
"""How the margin is applied per plant (module docstring, "Margin scales")."""

SPREAD_FLOOR = 1e-3
"""The least quantile band width (action units) of the ``spread`` scale, so that no plant's margin vanishes
where the two quantile trees meet."""

RIDGE_PENALTIES = np.logspace(-4, 3, 15)
"""The ridge penalties among which leave-one-out cross-validation chooses."""

BOOSTING = {"max_iter": 200, "learning_rate": 0.05, "max_leaf_nodes": 15, "min_samples_leaf": 20,
            "l2_regularization": 1.0, "early_stopping": False}
"""The trees of ``boosting`` and ``quantile-boosting`` (scikit-learn's defaults but a smaller learning
rate and larger leaves, for about a thousand noisy training plants)."""


def _regressor(kind: str, seed: int, quantile: float) -> Any:
    from sklearn.ensemble import HistGradientBoostingRegressor
    from sklearn.linear_model import RidgeCV
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import PolynomialFeatures, StandardScaler

    if kind == "ridge-quadratic":
        return make_pipeline(StandardScaler(), PolynomialFeatures(2, include_bias=False), StandardScaler(),
                             RidgeCV(alphas=RIDGE_PENALTIES))
    if kind == "boosting":
        return HistGradientBoostingRegressor(loss="squared_error", random_state=seed, **BOOSTING)
    if kind == "quantile-boosting":
        return HistGradientBoostingRegressor(loss="quantile", quantile=quantile, random_state=seed, **BOOSTING)
    raise ValueError(f"model kind must be one of {', '.join(MODEL_KINDS)}, got {kind!r}")


def fit_regression(kind: str, observations: np.ndarray, actions: np.ndarray, seed: int = 0,
                   quantile: float = QUANTILE) -> Any:
    """A fitted scikit-learn regressor of ``kind`` from ``observations`` to ``actions``.

    Parameters
    ----------
    kind : str
        One of :data:`MODEL_KINDS`.
    observations : ndarray, shape (n, d)
        The observations of the training plants.
    actions : ndarray, shape (n,)
        The oracle's action on each (its parameter in the environment's action coordinate).
    seed : int
        ``random_state`` of the trees (they draw nothing at random without early stopping or
        subsampling; set for definiteness).
    quantile : float
        The quantile that ``quantile-boosting`` estimates (0 < quantile < 1; the other kinds ignore it).

    Raises
    ------
    ValueError
        For an unknown kind, arrays of mismatched or wrong shape, fewer than 2 plants, a
        non-finite value, or a quantile outside (0, 1).
    """
    observations = np.asarray(observations, dtype=float)
    actions = np.asarray(actions, dtype=float)
    if observations.ndim != 2 or actions.shape != (observations.shape[0],):
        raise ValueError(f"observations must be (n, d) and actions (n,), got {observations.shape} and {actions.shape}")
    if observations.shape[0] < 2:
        raise ValueError(f"a regression needs at least 2 training plants, got {observations.shape[0]}")
    if not (np.all(np.isfinite(observations)) and np.all(np.isfinite(actions))):
        raise ValueError("observations and actions must be finite")
    if not 0 < quantile < 1:
        raise ValueError(f"quantile must lie strictly between 0 and 1, got {quantile!r}")
    from threadpoolctl import threadpool_limits

    model = _regressor(kind, seed, quantile)
    with threadpool_limits(1):
        model.fit(observations, actions)
    return model


@dataclass(frozen=True)
class Spread:
    """The per-plant scale of a ``spread`` margin: ``max(|upper(x) - lower(x)|, SPREAD_FLOOR) / mean``.

    Attributes
    ----------
    upper, lower : scikit-learn regressors
        The ``q`` and ``1 - q`` quantile trees of the oracle's action (:func:`fit_spread`).
    mean : float
        The mean floored width over the training plants (> 0), so that the scale averages 1 there.
    """

    upper: Any = field(repr=False)
    lower: Any = field(repr=False)
    mean: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.mean) and self.mean > 0):
            raise ValueError(f"the mean spread must be a finite number > 0, got {self.mean!r}")

    def width(self, observations: np.ndarray) -> np.ndarray:
        """The floored band width ``(n,)`` of a batch of observations ``(n, d)``."""
        rows = np.asarray(observations, dtype=float)
        upper = np.asarray(self.upper.predict(rows), dtype=float)
        return np.maximum(np.abs(upper - np.asarray(self.lower.predict(rows), dtype=float)), SPREAD_FLOOR)

    def scale(self, observations: np.ndarray) -> np.ndarray:
        """The margin's factor ``(n,)`` for a batch of observations ``(n, d)`` (mean 1 on the training plants)."""
        return self.width(observations) / self.mean


def fit_spread(observations: np.ndarray, actions: np.ndarray, seed: int = 0, quantile: float = QUANTILE) -> Spread:
    """The :class:`Spread` of the ``quantile`` and ``1 - quantile`` quantile trees fitted to the training plants.

    Raises
    ------
    ValueError
        As :func:`fit_regression`; also for ``quantile == 0.5`` (a band of no width).
    """
    if quantile == 0.5:
        raise ValueError("the spread margin needs a quantile other than 0.5 (the band between q and 1 - q)")
    upper = fit_regression("quantile-boosting", observations, actions, seed, quantile)
    lower = fit_regression("quantile-boosting", observations, actions, seed, 1.0 - quantile)
    spread = Spread(upper, lower, 1.0)
    return Spread(upper, lower, float(np.mean(spread.width(observations))))


@dataclass(frozen=True)
class LearnedRule:
    """A fitted regression with its safety margin: ``action = clip(f(x) + direction * margin * s(x))``,
    ``s = 1`` for a constant margin and ``spread.scale`` for a scaled one (module docstring, "Margin scales").

    Attributes
    ----------
    kind : str
        The model kind (:data:`MODEL_KINDS`).
    model : scikit-learn regressor
        ``f``, fitted by :func:`fit_regression`.
    margin : float
        The shift (>= 0, action units) towards the conservative side.
    direction : {1.0, -1.0}
        The sign of the action change that makes the design more conservative (larger ``mu`` or
        ``T_r``): ``+1`` where the parameter grows with the action.
    low, high : float
        The bounds of the action, to which the shifted prediction is clipped.
    observation_size : int
        The length of the observation vector.
    spread : Spread or None
        The per-plant scale of the margin; None for a constant margin.
    """

    kind: str
    model: Any = field(repr=False)
    margin: float
    direction: float
    low: float
    high: float
    observation_size: int
    spread: Spread | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.direction not in (1.0, -1.0):
            raise ValueError(f"direction must be 1 or -1, got {self.direction!r}")
        if not (np.isfinite(self.margin) and self.margin >= 0):
            raise ValueError(f"margin must be a finite number >= 0, got {self.margin!r}")
        if not self.low < self.high:
            raise ValueError(f"the action bounds must be increasing, got ({self.low!r}, {self.high!r})")

    def regression(self, observations: np.ndarray) -> np.ndarray:
        """``f`` on a batch of observations ``(n, d)``: the unshifted actions ``(n,)`` (each row's
        prediction is its own: the number of threads does not change it)."""
        return np.asarray(self.model.predict(np.asarray(observations, dtype=float)), dtype=float)

    def predict(self, observation: np.ndarray) -> np.ndarray:
        """The action (float32) for one observation ``(d,)`` -> ``(1,)``, or a batch ``(n, d)`` -> ``(n, 1)``.

        Raises
        ------
        ValueError
            If the observation's length is not :attr:`observation_size`, or it is not finite.
        """
        observation = np.asarray(observation, dtype=float)
        batch = observation.reshape(-1, observation.shape[-1]) if observation.ndim else observation.reshape(1, 1)
        if observation.ndim not in (1, 2) or batch.shape[1] != self.observation_size:
            raise ValueError(f"observation must have {self.observation_size} entries, got shape {observation.shape}")
        if not np.all(np.isfinite(batch)):
            raise ValueError("observation must be finite")
        shift = self.margin if self.spread is None else self.margin * self.spread.scale(batch)
        actions = np.clip(self.regression(batch) + self.direction * shift, self.low, self.high)
        actions = actions.astype(np.float32).reshape(-1, 1)
        return actions[0] if observation.ndim == 1 else actions

    def with_margin(self, margin: float) -> LearnedRule:
        """The same regression with another margin."""
        return LearnedRule(self.kind, self.model, float(margin), self.direction, self.low, self.high, self.observation_size,
                           self.spread)

    @property
    def margin_scale(self) -> str:
        """``constant`` or ``spread`` (:data:`MARGIN_SCALES`)."""
        return "constant" if self.spread is None else "spread"


def violation_bound(violations: int, plants: int, confidence: float) -> float:
    """The one-sided Clopper-Pearson upper bound on a violation rate (Clopper and Pearson, Biometrika 26, 1934).

    The rate ``p`` with ``P(Binomial(plants, p) <= violations) = 1 - confidence``: a rate above it
    would have given at most ``violations`` in ``plants`` with probability below ``1 - confidence``
    (``1.0`` when every plant violates).

    Raises
    ------
    ValueError
        For counts that are not ``0 <= violations <= plants``, ``plants >= 1``, or a confidence
        outside (0, 1).
    """
    if not (isinstance(plants, int | np.integer) and isinstance(violations, int | np.integer) and 0 <= violations <= plants
            and plants >= 1):
        raise ValueError(f"violations and plants must be integers with 0 <= violations <= plants and plants >= 1, "
                         f"got {violations!r} and {plants!r}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence!r}")
    if violations == plants:
        return 1.0
    from scipy.stats import beta

    return float(beta.ppf(confidence, violations + 1, plants - violations))


@dataclass(frozen=True)
class Validated:
    """What :func:`select` needs of one candidate on the validation plants: its mean cost, how many
    plants it violated a constraint on, of how many."""

    mean_cost: float
    violations: int
    plants: int


@dataclass(frozen=True)
class Selection:
    """The chosen rule and the validation results it was chosen by.

    ``costs[kind][i]`` is the mean validation cost of ``kind`` with ``margins[i]`` and
    ``violations[kind][i]`` its number of violating plants (of ``plants``).  With a
    ``violation_target``, ``certified[kind][i]`` says whether that candidate's violation rate was
    certified below the target (module docstring, "Certified margins") and ``is_certified`` whether the
    chosen one was; without a target both are empty / None.
    """

    rule: LearnedRule
    margins: tuple[float, ...]
    costs: Mapping[str, tuple[float, ...]]
    violations: Mapping[str, tuple[int, ...]] = field(default_factory=dict)
    plants: int = 0
    violation_target: float | None = None
    confidence: float | None = None
    certified: Mapping[str, tuple[bool, ...]] = field(default_factory=dict)
    is_certified: bool | None = None


def kind_confidence(confidence: float, kinds: int) -> float:
    """The confidence at which each of ``kinds`` model kinds is tested so that all hold together with
    ``confidence`` (Bonferroni)."""
    return 1.0 - (1.0 - confidence) / kinds


def _certified(violations: Sequence[int], margins: Sequence[float], plants: int, target: float, confidence: float) -> list[bool]:
    """Fixed-sequence testing of one kind's margins, from the largest down (module docstring)."""
    certified = [False] * len(margins)
    for i in sorted(range(len(margins)), key=lambda j: -margins[j]):
        if violation_bound(int(violations[i]), plants, confidence) > target:
            break
        certified[i] = True
    return certified


def select(
    rules: Sequence[LearnedRule], margins: Sequence[float], validate: Callable[[LearnedRule], Validated], *,
    violation_target: float | None = None, confidence: float = 0.95,
) -> Selection:
    """The rule and margin of the lowest validation cost, among the certified ones if a target is given.

    Every rule of ``rules`` (one per model kind, any margin) is tried with every margin; ties go to
    the larger margin (the safer rule), then to the earlier kind.  Only ``validate`` sees plants: the
    choice is made on whatever plants it plays, which must be validation plants.

    Parameters
    ----------
    rules : sequence of LearnedRule
        The fitted candidates, distinct kinds.
    margins : sequence of float
        The margins to try (>= 0).
    validate : callable
        A rule's :class:`Validated` on the validation plants (the same plants for every rule).
    violation_target : float or None
        The violation rate ``alpha`` to certify (0 < alpha < 1), or None to choose by cost alone.
    confidence : float
        ``1 - delta``, the probability over the validation plants with which the certified rates
        hold (module docstring, "Certified margins").

    Raises
    ------
    ValueError
        For no rule or no margin, a repeated kind, a negative margin, a target or confidence outside
        (0, 1), or candidates validated on different numbers of plants.
    """
    kinds = [rule.kind for rule in rules]
    if not rules or not len(margins):
        raise ValueError("select needs at least one rule and one margin")
    if len(set(kinds)) != len(kinds):
        raise ValueError(f"the rules' kinds must be distinct, got {kinds}")
    margins = tuple(float(m) for m in margins)
    if any(not (np.isfinite(m) and m >= 0) for m in margins):
        raise ValueError(f"margins must be finite numbers >= 0, got {list(margins)}")
    if violation_target is not None and not 0 < violation_target < 1:
        raise ValueError(f"violation_target must lie strictly between 0 and 1 or be None, got {violation_target!r}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence!r}")
    results = {rule.kind: [validate(rule.with_margin(m)) for m in margins] for rule in rules}
    plants = {result.plants for found in results.values() for result in found}
    if len(plants) != 1:
        raise ValueError(f"every candidate must be validated on the same number of plants, got {sorted(plants)}")
    n = plants.pop()
    costs = {kind: tuple(float(r.mean_cost) for r in found) for kind, found in results.items()}
    violations = {kind: tuple(int(r.violations) for r in found) for kind, found in results.items()}
    candidates = [(position, i) for position in range(len(rules)) for i in range(len(margins))]
    certified: dict[str, tuple[bool, ...]] = {}
    if violation_target is not None:
        level = kind_confidence(confidence, len(rules))
        certified = {kind: tuple(_certified(violations[kind], margins, n, violation_target, level)) for kind in kinds}
        passed = [(p, i) for p, i in candidates if certified[kinds[p]][i]]
        if not passed:
            fewest = min(violations[kind][i] for kind in kinds for i in range(len(margins)))
            passed = [(p, i) for p, i in candidates if violations[kinds[p]][i] == fewest]
        candidates = passed
    position, i = min(candidates, key=lambda c: (costs[kinds[c[0]]][c[1]], -margins[c[1]], c[0]))
    return Selection(rules[position].with_margin(margins[i]), margins, costs, violations, n,
                     violation_target, confidence if violation_target is not None else None, certified,
                     certified[kinds[position]][i] if certified else None)
