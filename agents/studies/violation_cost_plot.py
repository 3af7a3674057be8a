"""The figure of docs/scoring.md: the cost of a violating design against its grade, both maps.

    deadtime study violation-cost-plot docs/figures/violation_cost.png
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from agents.files.writer import write_figure
from envs.analysis.scoring import FEASIBLE_CAP, VIOLATION_BAND, violation_cost


def violation_cost_plot(path: str | Path) -> None:
    grades = np.logspace(-3, 4, 400)
    figure = Figure(figsize=(6.0, 3.2), dpi=100)
    FigureCanvasAgg(figure)
    axes = figure.subplots()
    for kind, style in (("graded", "--"), ("bounded", "-")):
        costs = [violation_cost({"violation": g}, True, kind) for g in grades]
        axes.plot(grades, costs, style, label=f'stable loop, "{kind}" (v0-v2)' if kind == "graded" else f'stable loop, "{kind}" (v3)')
    top = FEASIBLE_CAP + 1 + VIOLATION_BAND
    axes.axhline(top, color="k", lw=0.8, ls=":", label=f"unstable loop, both maps ({top:g})")
    axes.axhline(FEASIBLE_CAP, color="g", lw=0.8, ls=":", label=f"largest feasible cost ({FEASIBLE_CAP:g})")
    axes.set_xscale("log")
    axes.set_ylim(FEASIBLE_CAP - 1, top + 6)
    axes.set_xlabel("grade g: sum of the relative violations (e.g. Ms/Ms_max - 1)")
    axes.set_ylabel("cost")
    axes.legend(fontsize=7, loc="upper left")
    figure.tight_layout()
    write_figure(path, figure, "figure")
