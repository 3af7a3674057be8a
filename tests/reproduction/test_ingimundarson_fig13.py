"""Ingimundarson, Fig. 13 and the text of section 5.2: the lower bound on T_r/L_n for stability of the
MSP loop (49) under a relative dead-time error delta_L, and the design line of eq. 50.

Text: "if T_r_bar is larger than 0.4 it will be stable for any decrease in delta_L down to -1" --
reproduced (threshold 0.38).  "T_r_bar = 0.01 ... stable for delta_L in [-0.22, 0.14]" -- a known
discrepancy: the exact interval is about +-0.015; crossovers with omega L_n <= 10 alone give
[-0.220, 0.135] (the upper end then rounds to 0.13, a figure-reading difference).
"""

import math

import pytest

from baselines.reproduction.common import within_rounding
from baselines.reproduction.delay_errors import delay_error_margins, simulated_growth
from baselines.reproduction.ingimundarson_figures import fig13

CASE = "T_r/L_n = 0.01"
TRUNCATED = "T_r/L_n = 0.01, crossovers omega L_n <= 10 only"


@pytest.fixture(scope="module")
def reproduction():
    return fig13()


def test_threshold_for_any_decrease(reproduction):
    row = reproduction.row("every decrease, delta_L down to -1", "smallest T_r/L_n for stability")
    assert within_rounding(row)  # printed 0.4 (one decimal); computed 0.383
    assert row.computed < 0.4  # so the text's "larger than 0.4" is safe


def test_aggressive_tuning_interval_is_a_known_discrepancy(reproduction):
    low, high = reproduction.row(CASE, "smallest stable delta_L"), reproduction.row(CASE, "largest stable delta_L")
    assert not within_rounding(low) and not within_rounding(high)
    assert -0.02 < low.computed < 0 < high.computed < 0.02
    assert within_rounding(reproduction.row(TRUNCATED, "smallest stable delta_L"))  # -0.220 vs -0.22
    # 0.1346 vs 0.14: just outside half a unit (0.005); explained in the notes.
    truncated_high = reproduction.row(TRUNCATED, "largest stable delta_L")
    assert not within_rounding(truncated_high) and truncated_high.computed == pytest.approx(0.14, abs=0.006)


@pytest.mark.parametrize("quantity", ["smallest stable delta_L", "largest stable delta_L"])
def test_bisection_with_loop_margins_confirms_the_interval(reproduction, quantity):
    exact = reproduction.row(CASE, quantity).computed
    assert reproduction.row(CASE, quantity + ", bisection with loop_margins (extra)").computed == pytest.approx(exact, abs=1e-3)


def test_time_simulation_confirms_the_interval(reproduction):
    growth = {r.case: r.computed for r in reproduction.rows if r.quantity.startswith("simulated error growth")}
    assert math.isinf(growth["T_r/L_n = 0.01, delta_L = 0.1"])
    assert all(v < 0.1 for case, v in growth.items() if not case.endswith("0.1"))


def test_increase_is_more_dangerous_than_decrease():
    # "The bound is not symmetric around 0 ... an increase in dead-time is more likely to cause instability."
    lower, upper = delay_error_margins("msp", 0.5).interval()
    assert lower == -1.0 and upper < 1.0


@pytest.mark.parametrize("delta, grows", [(-0.9, False), (0.55, False), (0.58, True)])
def test_time_simulation_brackets_the_delay_margin(delta, grows):
    # T_r/L_n = 0.5: stable down to -1 and up to the delay margin 0.5634; simulation on either side of it.
    assert delay_error_margins("msp", 0.5).interval()[1] == pytest.approx(0.5634, abs=1e-4)
    assert (simulated_growth("msp", 0.5, delta, horizon=80.0) > 1) == grows


def test_eq_50_line_lies_above_the_bound(reproduction):
    assert reproduction.row("design line eq. 50", "min over delta_L of delay margin/delta_L (extra)").computed >= 1.0


def test_figure_is_written(reproduction, tmp_path):
    assert reproduction.figure(tmp_path).stat().st_size > 0
