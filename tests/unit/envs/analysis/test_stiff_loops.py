"""Stiff loops (a derivative filter far faster than the IAE's sample time): ``analyze`` reports the IAE
only where the compiled and the reference methods agree, and refuses the loop with one line otherwise.

The measurement behind :data:`~envs.analysis.loop_analysis.STIFF_LOOP` (the slow test): on 6 plants under
PIDs with ``n`` from 10 to ``1e10``, the two methods agree within ``1e-10`` relative up to a stiffness of 100.
"""

from __future__ import annotations

import io
import json
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pytest

from agents.cli import main
from envs.analysis.loop_analysis import STIFF_AGREEMENT, STIFF_LOOP, analyze, loop_stiffness
from envs.analysis.performance import iae
from envs.systems.controllers import PID
from envs.systems.plants import Plant

PLANT = Plant((1.0,), (2.0, 3.0, 1.0), dead_time=1.0)
PLANTS = [PLANT, Plant((1.0,), (10.0, 1.0), dead_time=5.0), Plant((1.0,), (10.0, 1.0), dead_time=1.0),
          Plant((2.0,), (1.0, 2.0, 1.0), dead_time=0.2), Plant((1.0,), (4.0, 4.0, 1.0), dead_time=2.0),
          Plant((1.0,), (1.0, 1.0), dead_time=0.1)]


def _pid(n: float) -> PID:
    return PID(kp=1.2, ti=2.5, td=0.4, n=n)  # stiffness 0.2 n on PLANT


def _cli(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        status = main(list(args))
    return status, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("n", [1e9, 1e10])
def test_a_filter_too_stiff_is_refused_with_one_line(n):
    """n = 1e10 gave a stable loop with an infinite IAE, n = 1e9 a wrong one."""
    controller = {"type": "pid", "kp": 1.2, "ti": 2.5, "td": 0.4, "n": n}
    status, out, err = _cli("analyze", "--plant", json.dumps(PLANT.to_dict()), "--controller", json.dumps(controller), "--json")
    assert status == 2 and out == "" and len(err.strip().splitlines()) == 1 and "stiff" in err and "Traceback" not in err


def test_a_stiff_loop_whose_methods_disagree_is_refused():
    assert loop_stiffness(PLANT, _pid(1e6)) == pytest.approx(2e5)
    with pytest.raises(ValueError, match="uncertain"):
        analyze(PLANT, _pid(1e6))


@pytest.mark.parametrize("n", [10.0, 1e5])
def test_below_and_above_the_threshold_the_reported_iae_is_the_compiled_one(n):
    """At n = 1e5 (stiffness 2e4) the methods agree within 2e-8: the compiled IAE is reported, unchanged."""
    result, compiled, reference = analyze(PLANT, _pid(n)), iae(PLANT, _pid(n)), iae(PLANT, _pid(n), method="reference")
    assert (result.iae_load, result.iae_setpoint) == (compiled.load, compiled.setpoint)
    assert result.iae_load == pytest.approx(reference.load, rel=STIFF_AGREEMENT)


def test_the_iae_of_a_stiff_loop_against_its_exact_value():
    """``e^{-0.1 s}/(s + 1)`` under a PID with ``K_p = 5``, ``T_i = 1``: the load error keeps its sign, so
    its IAE is ``T_i/K_p = 0.2`` exactly; analyze gives it to 2e-10 up to a stiffness of 7e3."""
    plant = PLANTS[-1]
    for n in (10.0, 1e3, 1e4):
        result = analyze(plant, PID(kp=5.0, ti=1.0, td=0.03, n=n))
        assert result.iae_load == pytest.approx(0.2, rel=2e-10)


@pytest.mark.slow
def test_the_methods_agree_up_to_the_stiffness_threshold():
    """The measurement behind STIFF_LOOP: relative agreement within 1e-10 (the compiled map's documented
    accuracy) for every stable loop of stiffness at most STIFF_LOOP; beyond it, disagreements above 1e-9."""
    worst_below, worst_above = 0.0, 0.0
    for plant in PLANTS:
        lag, delay = plant.residence_time - plant.dead_time, plant.dead_time
        for n in np.logspace(1, 7, 13):
            controller = PID(kp=0.5 * lag / max(delay, 0.1 * lag), ti=lag, td=0.3 * delay, n=float(n))
            a, b = iae(plant, controller), iae(plant, controller, method="reference")
            if not (np.isfinite(b.load) and np.isfinite(b.setpoint)):
                continue
            error = max(abs(a.load - b.load) / b.load, abs(a.setpoint - b.setpoint) / b.setpoint)
            if loop_stiffness(plant, controller) <= STIFF_LOOP:
                worst_below = max(worst_below, error)
            else:
                worst_above = max(worst_above, error)
    assert worst_below < 1e-10 and worst_above > 1e-9
