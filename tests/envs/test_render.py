"""``render()`` of the environments: the loop's output and control panels, diverged responses clipped."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from matplotlib.figure import Figure

import envs  # noqa: F401  (registers the ids)
from envs.rendering import _draw_bounded
from envs.interface import episode_of


def test_a_diverged_curve_does_not_set_the_axis() -> None:
    axes = Figure().subplots()
    time = np.linspace(0.0, 10.0, 101)
    bounded = 1.0 - np.exp(-time)
    diverged = np.exp(1.6 * time)  # 8.9e6 at the end
    _draw_bounded(axes, [(time, bounded, "-", "stable", False), (time, diverged, "--", "unstable", True)])
    low, high = axes.get_ylim()
    span = np.max(bounded) - np.min(bounded)
    assert (low, high) == (np.min(bounded) - 0.05 * span, np.max(bounded) + 0.05 * span)
    lines = {line.get_label(): line for line in axes.get_lines()}
    assert "unstable (diverged)" in lines
    assert np.max(lines["unstable (diverged)"].get_ydata()) <= high  # drawn only while inside the axes


def test_a_loop_that_diverges_altogether_is_drawn_within_a_bounded_range() -> None:
    axes = Figure().subplots()
    time = np.linspace(0.0, 10.0, 101)
    _draw_bounded(axes, [(time, np.sin(time) * np.exp(time), "-", "set point", True)])
    low, high = axes.get_ylim()
    assert high < 100 and low > -100  # 5 times the first tenth of the run, not the 2e4 it reaches


def test_render_shows_experiments_output_and_control() -> None:
    env = gym.make("DeadTime/PID-v0", render_mode="rgb_array")
    env.reset(seed=3)
    env.step(np.array([-1.0], dtype=np.float32))  # mu = 0.3: an unstable loop
    image = env.render()
    assert image.shape == (512, 512, 3) and image.dtype == np.uint8
    assert episode_of(env).committed == (0.3, 26.0)
