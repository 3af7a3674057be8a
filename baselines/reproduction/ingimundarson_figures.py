"""Ingimundarson, Figures 6, 7 and 13, and the numbers the text states about them.

* ``ingimundarson-fig6``: the upper limit of ``kappa`` against ``gamma`` for inequality (26), by
  bisection on ``kappa`` with the supremum over a frequency grid (plus the limit at infinity).
* ``ingimundarson-fig7``: the lower bound on ``T_r/L_n`` for stability of the FPPI loop (33)
  against the relative dead-time error ``delta_L``, and the design lines of eq. 28 and 29.
* ``ingimundarson-fig13``: the same for the MSP loop (49), and the design line of eq. 50.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from baselines.reproduction import plots
from baselines.reproduction.common import Reproduction, Row, printed, within_rounding
from baselines.reproduction.delay_errors import (
    bisect_delay_error,
    delay_error_margins,
    simulated_growth,
    smallest_time_constant,
)

__all__ = ["fig6", "fig7", "fig13", "kappa_upper_limit", "inequality_26_sup", "stability_bound"]

OMEGA = np.logspace(-4, 6, 4001)
"""Frequency grid ``omega_bar = T_r omega`` for the supremum in inequality (26)."""

TR_GRID = np.geomspace(0.005, 2.0, 48)
"""``T_r/L_n`` grid of Fig. 7 and 13."""

PAPER_MAX_FREQUENCY = 10.0
"""``omega L_n`` up to which the text's numbers for ``T_r/L_n = 0.01`` are reproduced (see notes)."""


# --------------------------------------------------------------------------- Fig. 6
def _inequality_26_max(kappa: float, gamma: float) -> float:
    """``max |gamma w (i kappa w + 1)/(i w + 1)^2|`` over the finite frequencies :data:`OMEGA`."""
    s = 1j * OMEGA
    return float(np.max(np.abs(gamma * OMEGA * (kappa * s + 1) / (s + 1) ** 2)))


def inequality_26_sup(kappa: float, gamma: float) -> float:
    """``sup |gamma w (i kappa w + 1)/(i w + 1)^2|`` over :data:`OMEGA` and ``w -> inf`` (``gamma kappa``)."""
    return float(max(_inequality_26_max(kappa, gamma), gamma * kappa))


def kappa_upper_limit(gamma: float, tolerance: float = 1e-10) -> float:
    """The largest ``kappa`` with ``sup <= 1`` in inequality (26), by bisection; 0 if none."""
    if inequality_26_sup(0.0, gamma) > 1:
        return 0.0
    low, high = 0.0, 2.0 / gamma + 1.0
    while high - low > tolerance:
        middle = 0.5 * (low + high)
        low, high = (middle, high) if inequality_26_sup(middle, gamma) <= 1 else (low, middle)
    return low


def _kappa_closed_form(gamma: float) -> float:
    """``1/gamma`` for ``gamma <= sqrt 2``, ``sqrt(4 - gamma^2)/2`` up to 2, then 0 (see the notes)."""
    if gamma <= math.sqrt(2):
        return 1 / gamma
    return math.sqrt(4 - gamma**2) / 2 if gamma < 2 else 0.0


def fig6() -> Reproduction:
    """Fig. 6: ``kappa`` and ``gamma`` for which inequality (26) holds; design lines eq. 27."""
    rows: list[Row] = []
    for gamma in (0.25, 0.5, 1.0, 1.2, 1.5, 1.8):
        limit = kappa_upper_limit(gamma)
        rows.append(Row(f"gamma = {gamma:g}", "upper limit of kappa (bisection)", None, limit))
        rows.append(Row(f"gamma = {gamma:g}", "upper limit of kappa (closed form)", None, _kappa_closed_form(gamma)))
    on_line = max(inequality_26_sup(1 / g, g) for g in np.linspace(0.01, 1.0, 100))
    finite = max(_inequality_26_max(1 / g, g) for g in np.linspace(0.01, 1.0, 100))
    rows.append(printed("design line kappa gamma = 1, gamma <= 1", "sup of (26) (edge: = 1)", "1", on_line))
    rows.append(Row("design line kappa gamma = 1, gamma <= 1", "largest value of (26) at finite omega (extra)", None, finite))
    rows.append(printed("gamma = 1, kappa = 1 (both lines)", "sup of (26) (edge: = 1)", "1", inequality_26_sup(1.0, 1.0)))
    notes = [
        "Bisection on kappa with the supremum of |gamma w (i kappa w + 1)/(i w + 1)^2| over 4001 log-spaced "
        "w in [1e-4, 1e6] together with its limit gamma kappa at w -> inf; a point is feasible if that "
        "supremum is <= 1.",
        "Closed form (derived here, a cross-check): the inequality is (1 - gamma^2 kappa^2) x^2 + (2 - gamma^2) x + 1 > 0 "
        "for all x = w^2 > 0, so kappa_max = 1/gamma for gamma <= sqrt 2, sqrt(4 - gamma^2)/2 for sqrt 2 < gamma < 2, "
        "and no kappa > 0 for gamma >= 2.",
        "The text's design lines: kappa = 1/gamma is the edge of the shaded area itself for gamma <= sqrt 2 (the supremum "
        "1 is approached only as w -> inf; at every finite frequency the value stays below 1), which is what the "
        "Remark after eq. 29 says; gamma = 1 with kappa <= 1 lies inside. So the rules gamma kappa <= 1, gamma <= 1 (eq. 27) "
        "are feasible, with eq. 28 on the boundary.",
        "The paper prints no numbers on Fig. 6; the rows are the computed curve and the two statements.",
    ]
    gamma = np.linspace(0.02, 2.2, 221)
    return Reproduction(
        name="ingimundarson-fig6",
        title="Ingimundarson Fig. 6: kappa and gamma fulfilling inequality (26); design lines eq. 27",
        rows=tuple(rows),
        notes=tuple(notes),
        figure=lambda directory: plots.kappa_gamma_plot(
            directory / "ingimundarson-fig6.png", gamma, np.array([kappa_upper_limit(g, 1e-6) for g in gamma]), "Fig. 6 (computed)"
        ),
    )


# --------------------------------------------------------------------------- Fig. 7 and 13
def stability_bound(kind: str, deltas: np.ndarray, max_frequency: float = math.inf) -> np.ndarray:
    """Lower bound on ``T_r/L_n`` for stability at each ``delta_L`` (the thick line of Fig. 7/13).

    The smallest grid ``T_r/L_n`` from which on, up the whole :data:`TR_GRID`, ``delta_L`` lies
    inside the stability interval of :class:`~baselines.reproduction.delay_errors.DelayErrorMargins`.
    """
    intervals = [delay_error_margins(kind, float(t)).interval(max_frequency) for t in TR_GRID]
    bound = np.full(len(deltas), np.nan)
    for j, delta in enumerate(deltas):
        for i in range(len(TR_GRID) - 1, -1, -1):
            lower, upper = intervals[i]
            if not (lower <= delta < upper or (delta == -1.0 and lower == -1.0)):
                break
            bound[j] = TR_GRID[i]
    return bound


def _design_ratio(kind: str, design) -> float:
    """``min over delta_L`` of (delay margin of the design) / ``delta_L``: >= 1 means the rule keeps its promise."""
    deltas = np.geomspace(0.02, 0.9, 10)
    return min(delay_error_margins(kind, float(design(d))).interval()[1] / d for d in deltas)


@lru_cache(maxsize=None)
def _delay_figure(kind: str) -> dict:
    aggressive = delay_error_margins(kind, 0.01)
    full, truncated = aggressive.interval(), aggressive.interval(PAPER_MAX_FREQUENCY)
    if kind == "fppi":
        def condition(interval):
            return interval[0] <= -1 and interval[1] >= 1
        designs = {f"eq. 28, T_n/L_n = {r:g}": (lambda d, r=r: math.sqrt(d * r)) for r in (0.5, 0.2, 0.1)}
        designs["eq. 29"] = lambda d: d
    else:
        def condition(interval):
            return interval[0] <= -1
        designs = {"eq. 50": lambda d: 2 * d / (1 - d)}
    below = max((w for w in aggressive.crossovers if w <= PAPER_MAX_FREQUENCY), default=0.0)
    above = min((w for w in aggressive.crossovers if w > PAPER_MAX_FREQUENCY), default=math.inf)
    return {
        "cutoffs": (below, above),
        "full": full,
        "truncated": truncated,
        "bisected": (bisect_delay_error(kind, 0.01, -1, step=0.002), bisect_delay_error(kind, 0.01, +1, step=0.002)),
        "threshold": smallest_time_constant(kind, condition, TR_GRID),
        "threshold_truncated": smallest_time_constant(kind, condition, TR_GRID, max_frequency=PAPER_MAX_FREQUENCY),
        "growth": {d: simulated_growth(kind, 0.01, d) for d in (0.1, 0.5 * full[1])},
        "designs": {label: _design_ratio(kind, f) for label, f in designs.items()},
        "design_functions": designs,
    }


def _delay_rows(kind: str, threshold_case: str, threshold_text: str, low_text: str, high_text: str) -> tuple[list[Row], dict]:
    data = _delay_figure(kind)
    (low, high), (low10, high10) = data["full"], data["truncated"]
    rows = [
        printed(threshold_case, "smallest T_r/L_n for stability", threshold_text, data["threshold"]),
        printed("T_r/L_n = 0.01", "smallest stable delta_L", low_text, low),
        printed("T_r/L_n = 0.01", "largest stable delta_L", high_text, high),
        printed("T_r/L_n = 0.01, crossovers omega L_n <= 10 only", "smallest stable delta_L", low_text, low10),
        printed("T_r/L_n = 0.01, crossovers omega L_n <= 10 only", "largest stable delta_L", high_text, high10),
        Row("T_r/L_n = 0.01", "smallest stable delta_L, bisection with loop_margins (extra)", None, data["bisected"][0]),
        Row("T_r/L_n = 0.01", "largest stable delta_L, bisection with loop_margins (extra)", None, data["bisected"][1]),
    ]
    for delta, growth in data["growth"].items():
        rows.append(Row(f"T_r/L_n = 0.01, delta_L = {delta:.3g}", "simulated error growth, last/second quarter (extra)", None, growth))
    for label, ratio in data["designs"].items():
        rows.append(Row(f"design line {label}", "min over delta_L of delay margin/delta_L (extra)", None, ratio))
    return rows, data


def _delay_notes(kind: str, data: dict, loop: str, claims: str) -> list[str]:
    (low, high), (low10, high10) = data["full"], data["truncated"]
    fppi = kind == "fppi"  # else the MSP's loop
    growth = ", ".join(f"delta_L = {d:.3g}: {'diverges' if math.isinf(g) else f'{g:.3g}'}" for d, g in data["growth"].items())
    return [
        f"Loop {loop} with e^{{-i w}} in the denominator (the printed e^{{+i w}} is a sign slip: normalizing "
        f"{'eq. 31' if fppi else 'eq. 47'} gives e^{{-i w}}). Nyquist stability by loop_margins with "
        f"integrators={1 if fppi else 2}: the denominator's zero at s = 0 is a pole of the loop, its only one "
        "in Re s >= 0. For each T_r/L_n the loop is stable for delta_L between the nearest values that turn a gain "
        "crossover onto -1 (increase: the delay margin of section 3; decrease: the same with the phase measured the "
        "other way); the bound is taken over a grid of 48 T_r/L_n in [0.005, 2] and bisected.",
        f"The text: {claims}",
        f"At T_r/L_n = 0.01 the loop has many gain crossovers up to omega L_n of about 1/T_r_bar; the ones above 10 "
        f"are the binding ones and give [{low:.3f}, {high:.3f}]. Keeping only crossovers with omega L_n <= 10 gives "
        f"[{low10:.3f}, {high10:.3f}], the text's numbers: the paper's frequency grid evidently ended at "
        f"omega L_n = 10 (any end between the crossovers at {data['cutoffs'][0]:.2f} and {data['cutoffs'][1]:.2f} gives the "
        "same; logspace(-2, 1) is a common default). The full-range interval is right: bisection on delta_L with loop_margins on the perturbed "
        f"loop gives [{data['bisected'][0]:.3f}, {data['bisected'][1]:.3f}], and a time simulation of the controller at "
        f"T_r/L_n = 0.01 ({growth}; below 1 decays) diverges at delta_L = 0.1, inside the text's interval.",
        f"The threshold with crossovers omega L_n <= 10 only is {data['threshold_truncated']:.4f} "
        f"(full range {data['threshold']:.4f}): the truncation does not matter there.",
        "Design lines (extra): for assumed errors delta_L in [0.02, 0.9], the delay margin of the designed loop over "
        f"delta_L is at least {min(data['designs'].values()):.2f} on every line"
        + (", so the recommended T_r lies above the stability bound as the text says." if min(data["designs"].values()) >= 1
           else ": some designs do NOT deliver the assumed delay margin, contrary to the text."),
    ]


def _delay_figure_callable(kind: str, name: str, title: str):
    def draw(directory: Path) -> Path:
        deltas = np.linspace(-1.0, 1.0, 401)
        x = np.linspace(0.005, 0.9 if kind == "msp" else 1.0, 200)
        lines = {label: (x, np.array([design(d) for d in x])) for label, design in _delay_figure(kind)["design_functions"].items()}
        return plots.delay_error_plot(
            directory / f"{name}.png", deltas, stability_bound(kind, deltas), stability_bound(kind, deltas, PAPER_MAX_FREQUENCY), lines, title
        )

    return draw


def _delay_reproduction(kind: str, name: str, title: str, figure_title: str, rows: list[Row], notes: list[str]) -> Reproduction:
    """Fig. 7 or 13 as a :class:`Reproduction`: ``notes`` plus the rounding note, and the figure."""
    return Reproduction(
        name=name,
        title=title,
        rows=tuple(rows),
        notes=tuple(notes) + tuple(_rounding_note(rows)),
        figure=_delay_figure_callable(kind, name, figure_title),
    )


def fig7() -> Reproduction:
    """Fig. 7: lower bound on ``T_r/L_n`` of the FPPI against the dead-time error; eq. 28/29 lines."""
    rows, data = _delay_rows("fppi", "delta_L anywhere in [-1, 1]", "0.22", "-0.2", "0.15")
    claims = "'if T_r_bar >= 0.22, delta_L can vary from -1 to 1' (reproduced) and 'T_r_bar = 0.01 would give a relative delay margin from -0.2 to 0.15' (not reproduced, see next note)."
    notes = _delay_notes("fppi", data, "eq. 33", claims)
    return _delay_reproduction(
        "fppi",
        "ingimundarson-fig7",
        "Ingimundarson Fig. 7: FPPI, lower bound on T_r/L_n for stability against delta_L (eq. 33)",
        "Fig. 7 (computed): FPPI, eq. 33",
        rows,
        notes,
    )


def fig13() -> Reproduction:
    """Fig. 13: lower bound on ``T_r/L_n`` of the MSP against the dead-time error; eq. 50 line."""
    rows, data = _delay_rows("msp", "every decrease, delta_L down to -1", "0.4", "-0.22", "0.14")
    claims = "'if T_r_bar is larger than 0.4 it will be stable for any decrease in delta_L down to -1' (reproduced: the computed threshold is below 0.4, see its row) and 'T_r_bar = 0.01 ... stable for delta_L in [-0.22, 0.14]' (not reproduced, see next note)."
    notes = _delay_notes("msp", data, "eq. 49", claims)
    high10 = data["truncated"][1]
    if abs(high10 - 0.14) > 0.005:
        notes.append(
            f"The truncated upper end {high10:.4f} rounds to 0.13, not the printed 0.14 (a difference of {0.14 - high10:.3f}): "
            "it comes from a single crossover (omega L_n near 7.3) whose delay margin phi/omega is read off the paper's "
            "figure or coarse grid; the truncation still explains the lower end and the size of both ends."
        )
    return _delay_reproduction(
        "msp",
        "ingimundarson-fig13",
        "Ingimundarson Fig. 13: MSP, lower bound on T_r/L_n for stability against delta_L (eq. 49)",
        "Fig. 13 (computed): MSP, eq. 49",
        rows,
        notes,
    )


def _rounding_note(rows: list[Row]) -> list[str]:
    off = [f"{r.case}: {r.quantity} = {r.computed:.4f} (paper {r.paper:g})" for r in rows if r.paper is not None and not within_rounding(r)]
    return ["Outside the printed rounding: " + "; ".join(off) + "."] if off else []
