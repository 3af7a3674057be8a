"""The response figures of ``deadtime evaluate`` (agents.evaluation.plots): a diverged
or off-scale loop is clipped and marked, and the axes follow the loops that stay on scale."""

from __future__ import annotations

import numpy as np

from agents.evaluation.plots import _response, response_range, responses_plot
from envs.systems.controllers import PID
from envs.systems.plants import Plant

PLANT = Plant.from_time_constants(1.0, [1.0], 0.5)
GOOD, DIVERGING = PID(0.8, 1.0), PID(8.0, 1.0)  # the second is unstable on the plant


def test_a_diverged_policy_does_not_set_the_response_axis():
    responses = {"good": _response(PLANT, GOOD, 1.0, 0.0), "diverging": _response(PLANT, DIVERGING, 1.0, 0.0)}
    assert responses["diverging"].diverged and np.nanmax(np.abs(responses["diverging"].output)) > 10
    curves = {name: r.output for name, r in responses.items()}
    (low, high), off = response_range(curves, {name: r.diverged for name, r in responses.items()})
    good = curves["good"]
    assert off == {"diverging"}
    assert low < float(np.min(good)) and high > float(np.max(good))
    assert high - low < 1.5 * (float(np.max(good)) - float(np.min(good))) + 1e-9


def test_an_off_scale_curve_that_did_not_diverge_is_clipped_too():
    t = np.linspace(0, 1, 50)
    (low, high), off = response_range({"a": np.sin(t), "b": 1e7 * t}, {})
    assert off == {"b"} and high < 2


def test_responses_figure_is_written(tmp_path):
    path = responses_plot(PLANT, {"good": GOOD, "diverging": DIVERGING}, tmp_path / "r.png", "test",
                          {"good": "good: cost 1.2", "diverging": "diverging: cost 26"})
    assert path.is_file() and path.stat().st_size > 10_000
