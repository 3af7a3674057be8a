"""The risk-conditioned design: ``a(x, r) = max(f_a(x), f_b(x) + s(x) q_{1-r})``, clipped to the action's range.

Per plant the oracle's fast search gives two labels (:mod:`agents.risk.labels`): the oracle's action
and the feasibility boundary's, the least conservative feasible action (in every structure a larger
action is the more conservative design: a larger relative parameter, ``parameter_from_action``).  A
design violates on a plant exactly when it is bolder than the boundary, so a design whose share of
violating plants is at most ``r`` is an upper ``1 - r`` quantile of the boundary given the
observation ``x``.  It is found by normalized split-conformal prediction (Papadopoulos, Proedrou,
Vovk and Gammerman 2002; Lei, G'Sell, Rinaldo, Tibshirani and Wasserman 2018, section 5.2), on three
disjoint splits of the training plants:

1. ``f_b``, a regression of the boundary's action on ``x``, and ``f_a``, one of the oracle's action
   (the design of least predicted cost), fitted on the first split;
2. ``s``, a regression of the absolute residual ``|b - f_b(x)|`` on ``x`` (the local scale), on the second;
3. the scores of the third split: the standardized residual ``z = (b - f_b(x)) / s(x)``, but ``-inf``
   where ``f_a(x) >= b`` (the design ``max(f_a, .)`` is then feasible whatever the quantile).  A design
   violates exactly when ``f_a(x) < b`` and ``z > q``, that is when the score exceeds ``q``.  The plants
   with no feasible design (every design violates) have no score; they are counted, ``n_0`` of the
   split's ``n`` plants.  ``q_{1-r}`` is the ``k``-th smallest of the ``n - n_0`` scores with
   ``k = ceil((n + 1)(1 - r))``: the rank of split-conformal prediction over all ``n`` plants with the
   ``n_0`` scored ``+inf`` (they sort last), so that on a new plant of the training distribution the
   design ``a(x, r)`` violates with probability at most ``r`` (the conformal guarantee, marginal over
   the plants), and not far below it: the maximum with ``f_a`` is part of the calibrated score.
   Among the feasible plants this is their own conformal quantile at the adjusted level
   ``(r - p_0) / (1 - p_0)``, ``p_0 = n_0 / n``, up to the rank's rounding (one rank, in the safe
   direction).  Where ``k > n - n_0`` the level is *unreachable*: no design violates on fewer than the
   share ``p_0`` of the plants; the design is then the most conservative one, and
   :meth:`RiskLearner.reachable` and :meth:`RiskLearner.floor` say so per plant.

With ``bands`` the third split's residuals are kept per band of the observation's noise feature
(``log_noise_ratio``), and a plant's quantile is its band's (Mondrian conformal prediction, Vovk,
Gammerman and Shafer 2005, ch. 4: the guarantee then holds within each band, and so does ``p_0``:
the plants with no feasible design, found at high noise, make no other band conservative).  With
``quantized_band``, the plants whose observation looks quantized have one band of their own: a
regression of the indicator of a sensor quantization on ``x``, fitted on the first split, above
one half (a function of ``x`` fitted apart from the third split, so a Mondrian taxonomy like the
noise bands).  A quantized sensor's plants have residuals of another law than the unquantized
plants of the same noise; sharing a band, one kind would be bold where the other is conservative.  The design never
goes bolder than ``f_a(x)``, the predicted optimum: the oracle's action is feasible, so it lies on
the boundary or beyond it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["SCALE_FLOOR", "RiskLearner", "conformal_quantile", "conformalized", "fit_learner", "fit_regressions", "looks_quantized", "regression",
           "split_indices"]

SCALE_FLOOR = 1e-3
"""The least local scale (in action units): a scale regression's prediction near 0 cannot make a
standardized residual explode."""


def conformal_quantile(scores: np.ndarray, risk: float, no_design: int = 0, n: int | None = None) -> float:
    """The ``ceil((n + 1)(1 - risk))``-th smallest of ``n`` scores: the sorted ``scores`` and ``no_design`` more
    of ``+inf`` (``n = len(scores) + no_design`` unless given); ``inf`` where the rank falls beyond ``scores``
    (module docstring, step 3)."""
    n = len(scores) + no_design if n is None else n
    rank = math.ceil((n + 1) * (1.0 - risk))
    if rank < 1:
        return -math.inf
    return float(scores[rank - 1]) if rank <= len(scores) else math.inf


@dataclass
class RiskLearner:
    """A fitted risk-conditioned learner of one structure (module docstring).

    Attributes
    ----------
    action_model, boundary_model, scale_model : regressions with ``predict(rows)``
    scores : list of numpy arrays
        Per band, the scores of the third split's plants with a feasible design, sorted.
    no_design : list of int
        Per band, the third split's plants with no feasible design (``n_0``).
    quantized_model : regression or None
        With a band of its own for the plants that look quantized: the regression of the quantization's
        indicator (that band is the last).
    band_edges : numpy array
        The inner edges of the bands in the noise feature (empty: one band).
    noise_feature : int
        The observation's index of the noise feature.
    low, high : float
        The action's range.
    observation_size : int
    """

    action_model: Any
    boundary_model: Any
    scale_model: Any
    scores: list = field(repr=False)
    band_edges: np.ndarray
    noise_feature: int
    low: float
    high: float
    observation_size: int
    no_design: list = field(default_factory=list)
    quantized_model: Any = None

    def _rows(self, observation: Any) -> np.ndarray:
        rows = np.asarray(observation, dtype=np.float64).reshape(-1, self.observation_size)
        return np.nan_to_num(rows, nan=0.0, posinf=1e6, neginf=-1e6)

    def bands(self, rows: np.ndarray) -> np.ndarray:
        band = np.searchsorted(self.band_edges, rows[:, self.noise_feature], side="right")
        quantized = getattr(self, "quantized_model", None)
        return band if quantized is None else np.where(looks_quantized(quantized, rows), len(self.band_edges) + 1, band)

    def _counts(self, band: int) -> tuple[int, int]:
        """``(n_0, n)`` of a band: its plants with no feasible design, and all its plants."""
        scores, no_design = self.scores[band], getattr(self, "no_design", None)
        if not no_design:  # a learner of the former files: the no-design plants among the scores, +inf
            return int(np.isposinf(scores).sum()), len(scores)
        return int(no_design[band]), len(scores) + int(no_design[band])

    def band_sizes(self) -> list[int]:
        """Per band, its calibration plants (with those of no feasible design)."""
        return [self._counts(b)[1] for b in range(len(self.scores))]

    def quantiles(self, rows: np.ndarray, risk: float, band: np.ndarray | None = None) -> np.ndarray:
        """Each row's ``q_{1-risk}`` (its band's, ``band`` if given; ``inf`` where unreachable)."""
        per_band = np.array([conformal_quantile(scores[np.isfinite(scores) | np.isneginf(scores)], risk, *self._counts(b))
                             for b, scores in enumerate(self.scores)])
        return per_band[self.bands(rows) if band is None else band]

    def floor(self, observation: Any) -> np.ndarray:
        """Each row's band's share ``p_0`` of calibration plants with no feasible design (no risk below it is reachable)."""
        per_band = np.array([n0 / max(n, 1) for n0, n in map(self._counts, range(len(self.scores)))])
        return per_band[self.bands(self._rows(observation))]

    def unreachable(self, risk: float) -> list[float]:
        """The floors ``p_0`` of the bands that do not reach ``risk`` (empty: every band reaches it)."""
        return [n0 / max(n, 1) for b, (n0, n) in enumerate(map(self._counts, range(len(self.scores))))
                if conformal_quantile(self.scores[b][~np.isposinf(self.scores[b])], risk, n0, n) == math.inf]

    def reachable(self, observation: Any, risk: float) -> np.ndarray:
        """Per row, whether its band reaches ``risk`` (a quantile below ``inf``); where not, the design is the most conservative."""
        return ~np.isposinf(self.quantiles(self._rows(observation), risk))

    def design(self, observation: Any, risk: float) -> np.ndarray:
        """The design actions (float64, one per row of ``observation``) at risk ``risk``."""
        return self.designs(observation, (risk,))[0][:, 0]

    def designs(self, observation: Any, risks: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
        """``(design actions, reachable)``, rows by ``risks``, the regressions evaluated once for all risks."""
        rows = self._rows(observation)
        action, boundary, scale, band = (self.action_model.predict(rows), self.boundary_model.predict(rows), self.scale(rows),
                                         self.bands(rows))
        quantiles = np.column_stack([self.quantiles(rows, risk, band) for risk in risks])
        bound = np.nan_to_num(boundary[:, None] + scale[:, None] * quantiles, posinf=self.high, neginf=self.low)
        return np.clip(np.maximum(action[:, None], bound), self.low, self.high), ~np.isposinf(quantiles)

    def scale(self, rows: np.ndarray) -> np.ndarray:
        return np.maximum(self.scale_model.predict(rows), SCALE_FLOOR)


def looks_quantized(model: Any, rows: np.ndarray) -> np.ndarray:
    """Per row, whether the regression of the quantization's indicator predicts above one half."""
    return model.predict(rows) > 0.5


def regression(kind: str, seed: int, loss: str = "squared_error") -> Any:
    """An unfitted regression of ``kind``: ``boosting`` (histogram gradient boosting) or ``mlp`` (a small
    network on standardized inputs; its loss is the squared error whatever ``loss``)."""
    if kind == "boosting":
        from sklearn.ensemble import HistGradientBoostingRegressor

        return HistGradientBoostingRegressor(loss=loss, max_iter=150, learning_rate=0.1, max_leaf_nodes=31,
                                             min_samples_leaf=20, l2_regularization=1e-3, early_stopping=False,
                                             random_state=seed)
    if kind == "mlp":
        from sklearn.neural_network import MLPRegressor
        from sklearn.pipeline import make_pipeline
        from sklearn.preprocessing import StandardScaler

        return make_pipeline(StandardScaler(), MLPRegressor(hidden_layer_sizes=(64, 64), alpha=1e-4, max_iter=300,
                                                            early_stopping=True, random_state=seed))
    raise ValueError(f"model must be boosting or mlp, got {kind!r}")


def split_indices(n: int, shares: tuple[float, float, float], seed: int) -> list[np.ndarray]:
    """Three disjoint random index sets of ``range(n)`` in the proportions ``shares``."""
    order = np.random.default_rng(seed).permutation(n)
    cuts = np.cumsum(np.asarray(shares, dtype=float) / sum(shares))[:2] * n
    return np.split(order, cuts.astype(int))


def fit_regressions(data: dict[str, np.ndarray], kind: str, seed: int,
                    shares: tuple[float, float, float] = (0.6, 0.2, 0.2)) -> tuple[Any, Any, Any, np.ndarray, np.ndarray, Any]:
    """Steps 1-2 of the module docstring: ``(action model, boundary model, scale model, third split's rows,
    their scores, quantization model)`` from the arrays of :func:`agents.risk.labels.records_arrays` (the
    quantization model ``None`` where the data have no ``quantization`` or no quantized plant)."""
    x, action, boundary = _rows(data["observation"]), data["action"], data["boundary"]
    first, second, third = split_indices(len(x), shares, seed)
    feasible = first[np.isfinite(boundary[first])]
    boundary_model = regression(kind, seed).fit(x[feasible], boundary[feasible])
    action_model = regression(kind, seed + 1).fit(x[first], action[first])
    second = second[np.isfinite(boundary[second])]
    residual = np.abs(boundary[second] - boundary_model.predict(x[second]))
    scale_model = regression(kind, seed + 2, loss="absolute_error").fit(x[second], residual)
    b = np.where(np.isfinite(boundary[third]), boundary[third], np.inf)
    z = (b - boundary_model.predict(x[third])) / np.maximum(scale_model.predict(x[third]), SCALE_FLOOR)
    # where the predicted optimum is already at least the boundary, the design max(f_a, ...) is feasible for every q
    z = np.where(action_model.predict(x[third]) >= b, -np.inf, z)
    quantized = (data["quantization"] > 0).astype(float) if "quantization" in data else np.zeros(len(x))
    quantized_model = regression(kind, seed + 3).fit(x[first], quantized[first]) if quantized[first].any() else None
    return action_model, boundary_model, scale_model, x[third], z, quantized_model


def conformalized(regressions: tuple[Any, ...], bands: int, noise_feature: int, low: float, high: float,
                  quantized_band: bool = False) -> RiskLearner:
    """Step 3 of the module docstring on the regressions of :func:`fit_regressions`: the third split's
    scores, sorted, and its plants with no feasible design, counted, in ``bands`` equal-count bands of its
    noise feature (and, with ``quantized_band`` and a quantization model, one more band of the plants that
    look quantized)."""
    action_model, boundary_model, scale_model, rows, z, quantized_model = regressions
    if not quantized_band:
        quantized_model = None
    apart = looks_quantized(quantized_model, rows) if quantized_model is not None else np.zeros(len(rows), bool)
    noise = rows[:, noise_feature]
    edges = np.quantile(noise[~apart], np.arange(1, bands) / bands) if bands > 1 else np.array([])
    band = np.where(apart, bands, np.searchsorted(edges, noise, side="right"))
    scored = ~np.isposinf(z)
    count = bands + (quantized_model is not None)
    scores = [np.sort(z[(band == b) & scored]) for b in range(count)]
    no_design = [int(np.sum((band == b) & ~scored)) for b in range(count)]
    return RiskLearner(action_model, boundary_model, scale_model, scores, np.asarray(edges, dtype=float), int(noise_feature),
                       float(low), float(high), rows.shape[1], no_design, quantized_model)


def _rows(observation: np.ndarray) -> np.ndarray:
    return np.nan_to_num(np.asarray(observation, dtype=np.float64), nan=0.0, posinf=1e6, neginf=-1e6)


def fit_learner(data: dict[str, np.ndarray], kind: str, seed: int, *, shares: tuple[float, float, float] = (0.6, 0.2, 0.2),
                bands: int = 1, noise_feature: int, low: float, high: float, quantized_band: bool = False) -> RiskLearner:
    """A :class:`RiskLearner` (module docstring): :func:`fit_regressions` then :func:`conformalized`."""
    return conformalized(fit_regressions(data, kind, seed, shares), bands, noise_feature, low, high, quantized_band)
