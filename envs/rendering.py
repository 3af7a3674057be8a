"""``render_mode="rgb_array"``: an image of an episode's experiments and of its designed loop.

Matplotlib is imported when an image is drawn, not before.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from envs.tuning_episode import TuningEpisode

__all__ = ["DIVERGED_RANGE", "render_episode"]

DIVERGED_RANGE = 5.0
"""``render()`` draws a diverging response until it leaves ``DIVERGED_RANGE`` times the first tenth
of its run (or the bounded responses' range, where there are any) and marks where it leaves."""


def _draw_bounded(axes: Any, curves: list[tuple[np.ndarray, np.ndarray, str, str, bool]]) -> None:
    """Draw ``(time, values, style, label, diverged)`` curves; the axis follows the bounded ones."""
    bounded = [values for _, values, *_, diverged in curves if not diverged]
    if bounded:
        low, high = min(float(np.nanmin(v)) for v in bounded), max(float(np.nanmax(v)) for v in bounded)
    else:
        start = np.concatenate([values[: max(1, len(values) // 10)] for _, values, *_ in curves])
        reach = DIVERGED_RANGE * max(float(np.nanmax(np.abs(start))), 1e-12)
        low, high = -reach, reach
    margin = 0.05 * (high - low or 1.0)
    low, high = low - margin, high + margin
    for time, values, style, label, diverged in curves:
        if not diverged:
            axes.plot(time, values, style, lw=1.0, label=label)
            continue
        outside = np.flatnonzero(~((values >= low) & (values <= high)))
        end = int(outside[0]) if outside.size else len(values)
        line, = axes.plot(time[:end], values[:end], style, lw=1.0, label=f"{label} (diverged)")
        if end < len(values):
            axes.plot(time[end - 1 if end else 0], np.clip(values[end - 1 if end else 0], low, high), "x",
                      color=line.get_color(), ms=8)
    axes.set_ylim(low, high)


def render_episode(episode: TuningEpisode) -> np.ndarray:
    """An image of the experiments' measured outputs so far and, once the design is committed, the
    loop's set-point and load responses on the true plant: the output in one panel, the control signal
    in another, labelled with the design's parameter and cost, time in units of the true ``T_ar``.  A
    diverging response is drawn until it leaves the axes and marked; the axes follow the bounded ones."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6.4, 6.4), dpi=80)
    canvas = FigureCanvasAgg(figure)
    experiments, output, control = figure.subplots(3, 1)
    scale = episode.plant.residence_time
    for name, result in episode.evidence.results.items():
        experiments.plot(result.timepts / scale, result.output, lw=0.8, label=name)
    experiments.set_title("experiments (measured output)", fontsize=9)
    if episode.evidence.results:
        experiments.legend(fontsize=7)
    if episode.controller is not None:
        _plot_loop(episode, output, control, scale)
    control.set_xlabel("t / T_ar", fontsize=8)
    figure.tight_layout()
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def _plot_loop(episode: TuningEpisode, output: Any, control: Any, scale: float) -> None:
    from envs.simulation.loops import closed_loop_response, simulation_step

    plant, controller = episode.plant, episode.controller
    dt = simulation_step(plant, controller)
    steps = int(min(40.0 * scale / dt, 20_000))
    gain = abs(plant.gain) * (scale if episode.integrating else 1.0)
    symbol = episode.kind.symbol
    curves = {output: [], control: []}
    for label, kwargs, unit, style in (("set point", {"setpoint": 1.0}, 1.0, "-"), ("load / |K|", {"load": 1.0}, gain, "--")):
        response = closed_loop_response(plant, controller, steps, dt, **kwargs)
        time = response.timepts / scale
        curves[output].append((time, response.output / unit, style, label, response.diverged))
        curves[control].append((time, response.control * unit, style, label, response.diverged))
    for axes, drawn in curves.items():
        _draw_bounded(axes, drawn)
    relative, cost = episode.committed
    output.set_title(f"designed loop on the true plant: {symbol} = {relative:.3g}, cost {cost:.3g}", fontsize=9)
    output.set_ylabel("y", fontsize=8)
    control.set_ylabel("u (load: u |K|)", fontsize=8)
    output.legend(fontsize=7)
