"""The figures of ``deadtime evaluate`` (matplotlib, Agg backend: no display needed).

* :func:`cost_distribution_plot`: one box per policy (log cost axis), with the cap of feasible
  costs (:data:`envs.scoring.FEASIBLE_CAP`) drawn: every point above it violates a constraint.
* :func:`responses_plot`: unit load (at the plant input) and unit set-point responses of one plant
  with several controllers, time in units of the true ``T_ar``, the load response divided by
  ``|K|`` (``|K_v| T_ar`` for integrating plants) as in the score.
* :func:`nyquist_plot`: the loop ``L(i omega)`` of each controller near ``-1``, with the circle
  ``|1 + L| = 1/Ms_max`` that a loop meeting ``Ms <= Ms_max`` does not enter (``Ms = 2`` for
  reference where the environment has no ``Ms`` constraint, as ``MSP-v0``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

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
    fig, ax = plt.subplots(figsize=(max(6.0, 0.45 * len(names) + 2), 4.8))
    data = [np.asarray(costs[name], dtype=float) for name in names]
    box = ax.boxplot(
        data, showmeans=True, patch_artist=True, showfliers=False,
        meanprops={"marker": "D", "markerfacecolor": "black", "markeredgecolor": "black", "markersize": 4},
    )  # fmt: skip
    jitter = np.random.default_rng(0)  # fixed: the figure is reproducible
    for k, values in enumerate(data, start=1):
        ax.scatter(k + jitter.uniform(-0.15, 0.15, values.size), values, s=6, color="0.3", alpha=0.6, zorder=3)
    colors = {"oracle": "tab:green", "oracle-full": "tab:olive", "agent": "tab:blue"}
    for patch, name in zip(box["boxes"], names):
        role = roles.get(name, "rule")
        patch.set_facecolor(colors.get(role, "tab:orange" if role.startswith("best rule") else "0.85"))
    ax.axhline(cap, color="tab:red", lw=0.8, ls="--", label=f"feasible cap {cap:g} (above: violation)")
    ax.set_yscale("log")
    ax.set_xticks(range(1, len(names) + 1), names, rotation=60, ha="right", fontsize=8)
    ax.set_ylabel("episode cost")
    ax.set_title(title)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _response(plant: Any, controller: Any, setpoint: float, load: float):
    from envs.loops import closed_loop_response, simulation_step

    dt = simulation_step(plant, controller)
    steps = min(int(np.ceil(_HORIZON * plant.step_time_scale() / dt)) + 1, _MAX_STEPS)
    return closed_loop_response(plant, controller, steps, dt, setpoint=setpoint, load=load)


def responses_plot(plant: Any, controllers: dict[str, Any], path: Path, title: str) -> Path:
    """Load and set-point responses of ``plant`` under each controller (by name)."""
    plt = _pyplot()
    scale = plant.step_time_scale()
    load_scale = abs(plant.gain) * (scale if plant.integrating else 1.0)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for name, controller in controllers.items():
        for ax, (setpoint, load, normalizer) in zip(axes, ((0.0, 1.0, load_scale), (1.0, 0.0, 1.0))):
            response = _response(plant, controller, setpoint, load)
            ax.plot(response.timepts / scale, response.output / normalizer, label=name + (" (diverged)" if response.diverged else ""))
    axes[0].set_title("unit load step at the plant input")
    axes[0].set_ylabel("y / |K|" + (" T_ar" if plant.integrating else ""))
    axes[1].set_title("unit set-point step")
    axes[1].set_ylabel("y")
    for ax in axes:
        ax.set_xlabel("t / T_ar")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def nyquist_plot(plant: Any, controllers: dict[str, Any], max_sensitivity: float | None, path: Path, title: str) -> Path:
    """Nyquist curves of ``L = P C_fb`` near ``-1`` with the ``Ms`` circle."""
    from envs.loops import loop_response

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
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
