"""``deadtime analyze`` and ``deadtime tune`` at the edges: dead times of 1e-6 to
1e-12 of the plant's time scale, gains of 1e-12 to 1e12, coefficients up to 1e300.

Each row gives a result (exit 0, one JSON object) or one line on stderr with exit 2 naming the field,
never a traceback, and with bounded work: every simulated run is bounded by
``envs.simulation.delay_systems.MAX_RUN_SAMPLES`` and a dead time below ``NEGLIGIBLE_DEAD_TIME T_ar`` is simulated as
none.  The work is bounded in CPU seconds outside numba's compiler (:data:`WORK_SECONDS`, tests/work_time.py),
not in wall seconds: a busy machine slows a row without making it do more.
In-process through ``agents.cli.main``, as tests/unit/agents/test_cli_analyze.py does.
"""

from __future__ import annotations

import io
import json
import tracemalloc
from contextlib import redirect_stderr, redirect_stdout

import pytest

from agents.cli import main
from work_time import work_seconds

PID = {"type": "pid", "kp": 1.2, "ti": 9, "td": 1.5, "n": 10}
WORK_SECONDS = 20.0
"""CPU seconds of one row outside the compiler.  Measured with an empty numba cache on two cores at load
12: 6.5 s for the first row of the process (its imports), at most 1.0 s for the others (the FPPI of
model gain 1e300: 0.13 s, beside 8.2 s of compiling; 31.5 s of wall time had been seen for it on a busy
machine); the bound is three times the slowest, so it only catches a run whose work is not bounded."""
MEMORY_BYTES = 200e6
"""Peak Python allocations of one row (a bounded run holds a few arrays of 2**17 floats)."""


def _run(argv):
    out, err = io.StringIO(), io.StringIO()
    tracemalloc.start()
    with work_seconds() as work, redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exit_:
            code = exit_.code
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return code, out.getvalue(), err.getvalue(), work.seconds, peak


def _check(argv, expect_result=None):
    code, out, err, seconds, peak = _run(argv)
    assert seconds < WORK_SECONDS and peak < MEMORY_BYTES, (seconds, peak)
    if code == 0:
        json.loads(out)  # one JSON object
        assert expect_result is not False, out
        return json.loads(out)
    assert code == 2 and expect_result is not True, (code, err)
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err


def _plant(num, den, delay):
    return json.dumps({"num": num, "den": den, "delay": delay})


@pytest.mark.parametrize("relative_delay", [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12])
@pytest.mark.parametrize("command", ["analyze", "tune"])
def test_tiny_dead_times_give_a_result(command, relative_delay):
    plant = _plant([1], [10, 1], relative_delay * 10)
    argv = ["analyze", "--plant", plant, "--controller", json.dumps(PID), "--json"] if command == "analyze" else \
        ["tune", "--rule", "simc-pi", "--plant", plant, "--json"]
    result = _check(argv, expect_result=True)
    analysis = result if command == "analyze" else result["analysis"]
    assert analysis["stable"] is True


@pytest.mark.parametrize("gain", [1e-12, 1e-8, 1e-4, 1.0, 1e4, 1e8, 1e12])
def test_gains_over_the_documented_range_give_the_same_normalized_figures(gain):
    """simc-pi on ``K e^{-5 s}/(10 s + 1)``: Ms and the set-point IAE do not depend on ``K``, the load IAE is
    proportional to it.  ``tune`` designs from the fixed procedure's identification,
    whose run to steady state may stop at another sample when the gain's rounding moves a test across its
    threshold (measured: 2.8e-7 relative at ``K = 1e-12``, below 1e-11 elsewhere), so the tolerance is the
    identification's own accuracy, 1e-3 (``envs.identification.experiment_base.SAMPLES_PER_RESIDENCE_TIME``).  The exact
    invariance of the scoring of one loop is tests/property/test_core_invariants.py."""
    reference = _check(["tune", "--rule", "simc-pi", "--plant", _plant([1.0], [10, 1], 5), "--json"], True)["analysis"]
    analysis = _check(["tune", "--rule", "simc-pi", "--plant", _plant([gain], [10, 1], 5), "--json"], True)["analysis"]
    assert analysis["ms"] == pytest.approx(reference["ms"], rel=1e-3)
    assert analysis["iae_setpoint"] == pytest.approx(reference["iae_setpoint"], rel=1e-3)
    assert analysis["iae_load"] / gain == pytest.approx(reference["iae_load"], rel=1e-3)


@pytest.mark.parametrize(
    "plant, field",
    [
        (([1e300], [10, 1], 5), "plant.num"),
        (([1e13], [10, 1], 5), "plant.num"),
        (([1e-13], [10, 1], 5), "plant.num"),
        (([1], [1e300, 1], 5), "plant.den"),
        (([1], [1e200, 1e200, 1], 1), "plant.den"),
        (([1], [1, 1e300], 1), "plant.num"),
        (([1e300], [1e300, 1e300], 1), None),  # a valid plant of gain 1, T_ar 2: a result
        (([1], [10, 1], 1e300), "plant.delay"),
        (([1], [1e-13, 1], 1e-13), "plant.den"),
    ],
)
@pytest.mark.parametrize("command", ["analyze", "tune"])
def test_extreme_coefficients_are_refused_in_one_line_naming_the_field(command, plant, field):
    text = _plant(*plant)
    argv = ["analyze", "--plant", text, "--controller", json.dumps(PID), "--json"] if command == "analyze" else \
        ["tune", "--rule", "simc-pi", "--plant", text, "--json"]
    outcome = _check(argv, expect_result=None if field is None else False)
    if field is not None:
        assert field in outcome


@pytest.mark.parametrize(
    "controller",
    [
        {"type": "pid", "kp": 1e300, "ti": 9, "td": 1.5, "n": 10},
        {"type": "pid", "kp": 1.2, "ti": 1e-300, "td": 0, "n": 10},
        {"type": "pid", "kp": 1.2, "ti": 1e300, "td": 1e300, "n": 10},
        {"type": "fppi", "model": {"gain": 1, "time_constant": 10, "dead_time": 1e-12}, "tr": 1, "tf": 1},
        {"type": "fppi", "model": {"gain": 1e300, "time_constant": 10, "dead_time": 5}, "tr": 1, "tf": 1},
    ],
)
def test_extreme_controllers_give_a_result_or_one_line(controller):
    _check(["analyze", "--plant", _plant([1], [10, 1], 5), "--controller", json.dumps(controller), "--json"])
