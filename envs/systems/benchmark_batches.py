"""The papers' fixed test batches of plants: Gorez-Klan P1, P2 and Ingimundarson's stable and
integrating processes (:func:`benchmark_plants`), the ``benchmark`` family's draws
(:mod:`envs.systems.families`).

References
----------
.. [1] R. Gorez, P. Klan, "Simple models for process control", section 4, eq. 4-15, 4-16.
.. [2] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, section 4.4 (Table 1) and section 5.3 (Table 2).
"""

from __future__ import annotations

import numpy as np

from envs.systems.plants import Plant
from envs.systems.shapes import _lags

__all__ = ["benchmark_plants"]


_KINDS = ("stable", "integrating", "all")


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
