"""PNG figures of the reproductions (matplotlib's object API with the Agg canvas; no pyplot state).

Each ``*_plot`` function draws one figure from computed data, writes it to ``path`` (creating the
directory) and returns ``path``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ["step_responses", "kappa_gamma_plot", "delay_error_plot"]


def _save(figure: Figure, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    FigureCanvasAgg(figure)
    figure.savefig(path, dpi=120)
    return path


def step_responses(path: Path, timepts: np.ndarray, curves: dict[str, dict[str, np.ndarray]], title: str) -> Path:
    """One panel per case, one line per labelled response."""
    figure = Figure(figsize=(5 * len(curves), 3.6), layout="constrained")
    axes = figure.subplots(1, len(curves), squeeze=False)[0]
    styles = ["-", "--", "-."]
    for ax, (case, lines) in zip(axes, curves.items()):
        for style, (label, values) in zip(styles, lines.items()):
            ax.plot(timepts, values, style, label=label)
        ax.set_title(case)
        ax.set_xlabel("t / T_ar")
        ax.grid(True, alpha=0.3)
        ax.legend()
    figure.suptitle(title)
    return _save(figure, path)


def kappa_gamma_plot(path: Path, gamma: np.ndarray, kappa_max: np.ndarray, title: str) -> Path:
    """Fig. 6: the feasible region of inequality (26) and the design lines of eq. 27."""
    figure = Figure(figsize=(5.5, 4.2), layout="constrained")
    ax = figure.subplots()
    ax.fill_between(gamma, 0, kappa_max, color="0.85", label="inequality (26) holds")
    ax.plot(gamma, kappa_max, "k-", lw=2, label="upper limit of kappa (bisection)")
    ax.plot(gamma, 1 / gamma, "b--", label="design line kappa = 1/gamma")
    ax.axvline(1.0, color="r", ls="--", label="design line gamma = 1")
    ax.set_xlim(0, gamma[-1])
    ax.set_ylim(0, 6)
    ax.set_xlabel("gamma = T_f_bar / T_r")
    ax.set_ylabel("kappa = T_n / T_r")
    ax.set_title(title)
    ax.legend(loc="upper right")
    return _save(figure, path)


def delay_error_plot(
    path: Path,
    deltas: np.ndarray,
    bound: np.ndarray,
    truncated_bound: np.ndarray,
    design_lines: dict[str, tuple[np.ndarray, np.ndarray]],
    title: str,
) -> Path:
    """Fig. 7 / 13: the lower bound on ``T_r/L_n`` for stability against ``delta_L``, and design lines."""
    figure = Figure(figsize=(6, 4.5), layout="constrained")
    ax = figure.subplots()
    ax.plot(deltas, bound, "k-", lw=2.5, label="lower bound for stability (all frequencies)")
    ax.plot(deltas, truncated_bound, "k:", lw=1.2, label="same, crossovers with omega L_n <= 10 only")
    for (label, (x, y)), style in zip(design_lines.items(), ["--", "--", "--", "-"]):
        ax.plot(x, y, style, lw=1, label=label)
    ax.set_yscale("log")
    ax.set_xlim(-1, 1)
    ax.set_xlabel("delta_L = delta L / L_n")
    ax.set_ylabel("T_r / L_n")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    return _save(figure, path)
