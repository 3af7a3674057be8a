"""The figures of ``deadtime evaluate`` (matplotlib, Agg backend: no display needed).

* :func:`cost_distribution_plot`: one box per policy (log cost axis, plain tick labels), with the
  cap of feasible costs (:data:`envs.analysis.scoring.FEASIBLE_CAP`) drawn: every point above it violates a
  constraint; a legend for every colour (role) and marker (mean, one plant).
* :func:`responses_plot`: unit load (at the plant input) and unit set-point responses of one plant
  with several controllers, output above and control signal ``u`` below, time in units of the true
  ``T_ar`` (and in the plant's own unit on the top axis), the load response divided by ``|K|``
  (``|K_v| T_ar`` for integrating plants) as in the score; curves labelled with cost and
  parameter, diverged or off-scale curves clipped and marked (:func:`response_range`).
* :func:`nyquist_plot`: the loop ``L(i omega)`` of each controller near ``-1``, with the circle
  ``|1 + L| = 1/Ms_max`` that a loop meeting ``Ms <= Ms_max`` does not enter (``Ms = 2`` for
  reference where the environment has no ``Ms`` constraint, as ``MSP-v0``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from agents.files.writer import write_figure

__all__ = ["cost_distribution_plot", "nyquist_plot", "responses_plot"]

_HORIZON = 12.0  # in T_ar
_MAX_STEPS = 20_000


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def cost_distribution_plot(costs: dict[str, np.ndarray], roles: dict[str, str], path: Path, title: str, cap: float) -> Path:
    """Box plot of the per-plant costs of each policy, sorted by mean cost (log scale)."""
    plt = _pyplot()
    names = sorted(costs, key=lambda name: float(np.mean(costs[name])))
    fig, ax = plt.subplots(figsize=(max(6.0, 0.45 * len(names) + 2) + 2.5, 4.8))
    data = [np.asarray(costs[name], dtype=float) for name in names]
    box = ax.boxplot(
        data, showmeans=True, patch_artist=True, showfliers=False,
        meanprops={"marker": "D", "markerfacecolor": "black", "markeredgecolor": "black", "markersize": 4},
    )  # fmt: skip
    jitter = np.random.default_rng(0)  # fixed: the figure is reproducible
    for k, values in enumerate(data, start=1):
        ax.scatter(k + jitter.uniform(-0.15, 0.15, values.size), values, s=6, color="0.3", alpha=0.6, zorder=3)
    colors = {"oracle": "tab:green", "oracle-full": "tab:olive", "agent": "tab:blue", "learned rule": "tab:purple"}
    for patch, name in zip(box["boxes"], names):
        role = roles.get(name, "rule")
        patch.set_facecolor(colors.get(role, "tab:orange" if role.startswith("best rule") else "0.85"))
    ax.axhline(cap, color="tab:red", lw=0.8, ls="--", label=f"feasible cap {cap:g} (above: violation)")
    ax.set_yscale("log")
    from matplotlib.patches import Patch
    from matplotlib.ticker import FuncFormatter, NullFormatter

    ax.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())
    shown_roles = {roles.get(name, "rule") for name in names}
    keys = [Patch(facecolor=color, label=role) for role, color in colors.items() if role in shown_roles]
    if any(role.startswith("best rule") for role in shown_roles):
        keys.append(Patch(facecolor="tab:orange", label="best rule"))
    keys.append(Patch(facecolor="0.85", label="rule"))
    keys.append(plt.Line2D([], [], ls="", marker="D", color="black", markersize=4, label="mean (box: quartiles; whiskers 1.5 IQR)"))
    keys.append(plt.Line2D([], [], ls="", marker="o", color="0.3", markersize=3, alpha=0.6, label="one plant"))
    ax.set_xticks(range(1, len(names) + 1), names, rotation=60, ha="right", fontsize=8)
    ax.set_ylabel("episode cost")
    ax.set_title(title)
    ax.legend(handles=[*ax.get_legend_handles_labels()[0], *keys], loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)
    fig.tight_layout()
    write_figure(path, fig, 110)
    plt.close(fig)
    return path


def _response(plant: Any, controller: Any, setpoint: float, load: float):
    from envs.simulation.loops import closed_loop_response, simulation_step

    dt = simulation_step(plant, controller)
    steps = min(int(np.ceil(_HORIZON * plant.step_time_scale() / dt)) + 1, _MAX_STEPS)
    return closed_loop_response(plant, controller, steps, dt, setpoint=setpoint, load=load)


_MARKERS = ("o", "s", "^", "v", "D", "P", "X", "*")
_OFF_SCALE = 10.0  # a curve whose peak exceeds this many times the on-scale curves' range is clipped


def response_range(curves: dict[str, np.ndarray], diverged: dict[str, bool]) -> tuple[tuple[float, float], set[str]]:
    """The axis range of the on-scale curves, and the names of the curves that are not.

    A curve is off scale if its simulation diverged, it is not finite, or its peak ``|y|`` exceeds
    ``_OFF_SCALE`` times that of the largest other curve that is on scale (so that one loop near
    instability, e.g. at 1e7, does not flatten every other curve to a line at 0).  The range is
    that of the on-scale curves with a 10% margin.
    """
    peaks = {name: float(np.max(np.abs(y))) if y.size and np.all(np.isfinite(y)) else np.inf for name, y in curves.items()}
    off = {name for name in curves if diverged.get(name, False) or not np.isfinite(peaks[name])}
    for name in sorted(curves, key=lambda n: peaks[n], reverse=True):
        others = [peaks[n] for n in curves if n != name and n not in off]
        if name not in off and others and peaks[name] > _OFF_SCALE * max(max(others), 1e-12):
            off.add(name)
    kept = [curves[n] for n in curves if n not in off] or [np.zeros(1)]
    low, high = min(float(np.min(y)) for y in kept), max(float(np.max(y)) for y in kept)
    pad = 0.1 * max(high - low, 1e-9)
    return (low - pad, high + pad), off


def responses_plot(plant: Any, controllers: dict[str, Any], path: Path, title: str, labels: dict[str, str] | None = None) -> Path:
    """Load and set-point responses of ``plant`` under each controller (by name): the output in the
    top panels, the control signal ``u`` below, time in ``T_ar`` (bottom axis) and in the plant's
    own time unit (top axis).

    Each curve has its own colour and marker and its legend entry ``labels[name]`` (e.g. cost and
    parameter).  Diverged and off-scale curves (:func:`response_range`) are drawn dashed until they
    leave the range of the others, marked there with an ``x`` and labelled so; the axes follow the
    on-scale curves.
    """
    plt = _pyplot()
    scale = plant.step_time_scale()
    load_scale = abs(plant.gain) * (scale if plant.integrating else 1.0)
    fig, axes = plt.subplots(2, 2, figsize=(11, 6.5), sharex="col")
    cases = ((0.0, 1.0, load_scale), (1.0, 0.0, 1.0))
    names = list(controllers)
    responses = {(name, k): _response(plant, controllers[name], *case[:2]) for name in names for k, case in enumerate(cases)}
    clipped: set[str] = set()
    for k, (_, _, normalizer) in enumerate(cases):
        for row, signal in enumerate(("output", "control")):
            ax = axes[row, k]
            curves = {name: getattr(responses[name, k], signal) / (normalizer if signal == "output" else 1.0) for name in names}
            (low, high), off = response_range(curves, {name: responses[name, k].diverged for name in names})
            clipped |= off
            for j, name in enumerate(names):
                t, y = responses[name, k].timepts / scale, curves[name]
                style = {"color": f"C{j % 10}", "marker": _MARKERS[j % len(_MARKERS)], "markevery": max(len(t) // 12, 1),
                         "markersize": 4, "lw": 1.2}
                if name in off:  # drawn until it leaves the range, clipped there and marked
                    y = np.clip(np.nan_to_num(y, nan=high, posinf=high, neginf=low), low, high)
                    leaves = np.flatnonzero((y >= high) | (y <= low))
                    end = int(leaves[0]) + 1 if leaves.size else y.size
                    ax.plot(t[:end], y[:end], ls="--", alpha=0.8, **style)
                    ax.plot(t[end - 1], y[end - 1], "x", color=style["color"], markersize=10, mew=2.5)
                else:
                    ax.plot(t, y, **style)
            ax.set_ylim(low, high)
            ax.grid(alpha=0.3)
            ax.ticklabel_format(axis="y", style="plain", useOffset=False)
    axes[0, 0].set_title("unit load step at the plant input")
    axes[0, 1].set_title("unit set-point step")
    axes[0, 0].set_ylabel("y / |K|" + (" T_ar" if plant.integrating else ""))
    axes[0, 1].set_ylabel("y")
    axes[1, 0].set_ylabel("u")
    axes[1, 1].set_ylabel("u")
    for ax in axes[1]:
        ax.set_xlabel("t / T_ar")
    for ax in axes[0]:
        top = ax.secondary_xaxis("top", functions=(lambda x: x * scale, lambda x: x / scale))
        top.set_xlabel(f"t (plant time units; T_ar = {scale:.3g})", fontsize=8)
    handles = [
        plt.Line2D([], [], color=f"C{j % 10}", marker=_MARKERS[j % len(_MARKERS)], ls="--" if name in clipped else "-",
                   label=(labels or {}).get(name, name) + (" (diverged or off scale: drawn until it leaves the axes, x)" if name in clipped else ""))
        for j, name in enumerate(names)
    ]
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 2), fontsize=8, frameon=False)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.04 + 0.035 * ((len(handles) + 1) // 2), 1, 1))
    write_figure(path, fig, 110)
    plt.close(fig)
    return path


def nyquist_plot(plant: Any, controllers: dict[str, Any], max_sensitivity: float | None, path: Path, title: str) -> Path:
    """Nyquist curves of ``L = P C_fb`` near ``-1`` with the ``Ms`` circle."""
    from envs.simulation.loops import loop_response

    plt = _pyplot()
    scale = plant.step_time_scale()
    omega = np.logspace(-3, 3, 24_000) / scale  # dense: loops with dead times spin fast at high frequency
    fig, ax = plt.subplots(figsize=(6, 6))
    for name, controller in controllers.items():
        values = loop_response(plant, controller, omega)
        ax.plot(values.real, values.imag, lw=1, label=name)
    ax.plot([-1], [0], "k+", ms=10)
    angle = np.linspace(0, 2 * np.pi, 200)
    if max_sensitivity is not None:
        radius = 1.0 / max_sensitivity
        ax.plot(-1 + radius * np.cos(angle), radius * np.sin(angle), "r--", lw=1, label=f"Ms = {max_sensitivity:g} (constraint)")
    else:  # no Ms constraint (MSP-v0): the usual Ms = 2 for reference
        ax.plot(-1 + 0.5 * np.cos(angle), 0.5 * np.sin(angle), "--", color="0.5", lw=1, label="Ms = 2 (reference, no constraint)")
    ax.set_xlim(-3, 1.5)
    ax.set_ylim(-3, 1.5)
    ax.set_aspect("equal")
    ax.set_xlabel("Re L(i omega)")
    ax.set_ylabel("Im L(i omega)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title(title)
    fig.tight_layout()
    write_figure(path, fig, 110)
    plt.close(fig)
    return path
