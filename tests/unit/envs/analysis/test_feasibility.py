"""The batched feasibility figures (envs/analysis/feasibility.py) against the full analysis.

:func:`envs.analysis.feasibility.feasibility_margins` runs the same compiled steps as
:func:`envs.analysis.loop_analysis.plant_margins` and skips only figures no constraint reads, so the
figures it returns are compared for equality, not within a tolerance (measured difference: none, on
a few hundred designs of every structure): the identified v3 episodes' models of every structure, a
log grid of designs across each structure's whole parameter range (unstable designs included), the
gain margin asked for and not.
"""

from __future__ import annotations

import dataclasses
import math

import gymnasium
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from envs.analysis.feasibility import feasibility_margins
from envs.analysis.loop_analysis import plant_margins
from envs.interface import episode_of
from envs.structures import PARAMETER_RANGES, STRUCTURES, design, relative_scale

NAMES = ("PID", "FPPI", "MSP", "PI")
PLANTS = 12
DESIGNS = 25
SEED = 30_000_000


def _loops(name: str):
    """``(plant, controllers)`` of :data:`PLANTS` fixed-mode v3 episodes: the designs of the identified
    model on a log grid from a tenth of the relative parameter's range's low end to its high end."""
    env = gymnasium.make(f"DeadTime/{name}-v3", experiments="fixed")
    episode = episode_of(env)
    for k in range(PLANTS):
        env.reset(seed=SEED + k)
        model = STRUCTURES[episode.structure].model_of(episode.identification)
        unit = relative_scale(episode.structure, model)
        low, high = PARAMETER_RANGES[episode.structure]
        controllers = [design(episode.structure, model, r * unit) for r in np.geomspace(low / 10, high, DESIGNS)]
        if hasattr(controllers[0], "kp"):  # a PI's designs stay stable: one with fifty times the gain
            controllers.append(dataclasses.replace(controllers[0], kp=50 * controllers[0].kp))
        yield episode.plant, controllers
    env.close()


@pytest.mark.parametrize("name", NAMES)
def test_figures_equal_the_full_analysis(name):
    unstable = 0
    for plant, controllers in _loops(name):
        with_gain = feasibility_margins(plant, controllers, gain_margin=True)
        without = feasibility_margins(plant, controllers)
        for controller, full, fast, free in zip(controllers, (plant_margins(plant, c) for c in controllers), with_gain, without):
            assert fast.stable == free.stable == full.stable
            if not full.stable:
                unstable += 1
                assert fast.delay_margin == 0.0 == full.delay_margin
                continue
            figures = (full.ms, full.gain_margin, full.phase_margin_deg, full.delay_margin)
            assert (fast.ms, fast.gain_margin, fast.phase_margin_deg, fast.delay_margin) == figures
            assert (free.ms, free.phase_margin_deg, free.delay_margin) == (full.ms, full.phase_margin_deg, full.delay_margin)
            assert math.isnan(free.gain_margin)
    assert unstable > 0  # both kinds of loop were compared


def test_one_call_equals_one_call_per_design():
    plant, controllers = next(_loops("FPPI"))
    together = feasibility_margins(plant, controllers, gain_margin=True)
    alone = [feasibility_margins(plant, [c], gain_margin=True)[0] for c in controllers]
    assert [repr(m) for m in together] == [repr(m) for m in alone]
    assert feasibility_margins(plant, []) == []


@pytest.mark.parametrize("name", NAMES)
def test_a_screened_design_is_infeasible_by_the_full_analysis(name):
    bound, screened = 2.0, 0
    for plant, controllers in _loops(name):
        for controller, fast in zip(controllers, feasibility_margins(plant, controllers, screen=bound)):
            full = plant_margins(plant, controller)
            if fast is None:
                screened += 1
                assert not full.stable or full.ms > bound
            else:
                assert (fast.stable, fast.delay_margin) == (full.stable, full.delay_margin)
    assert screened > 0
