"""Gorez-Klan section 3, "Robustness with proposed controller settings": gain and phase margins
of the model loop e^{-D_2 s}/(mu D_2 s) (eq. 3-12 .. 3-14) for mu = 1.3, 1.5, 2, 3, plus the
true P1/P2 loops with the series PID of eq. 3-11 as extras.
"""

import math

import pytest

from baselines.reproduction.common import within_rounding
from baselines.reproduction.gorez_klan import MU_TABLE, mu_robustness


@pytest.fixture(scope="module")
def reproduction():
    return mu_robustness()


@pytest.mark.parametrize("mu", [m for m, _, _ in MU_TABLE])
@pytest.mark.parametrize("quantity", ["gain margin", "phase margin [deg]"])
def test_table_is_reproduced(reproduction, mu, quantity):
    # Printed to 1 decimal (gain) and whole degrees (phase): half a unit of the last printed place.
    row = reproduction.row(f"mu = {mu}", quantity)
    assert within_rounding(row)


@pytest.mark.parametrize("mu", [m for m, _, _ in MU_TABLE])
def test_model_loop_matches_the_closed_form(reproduction, mu):
    # eq. 3-13, 3-14: GM = mu pi/2, PM = pi/2 - 1/mu rad; loop_margins locates crossovers to ~1e-13.
    m = float(mu)
    assert reproduction.row(f"mu = {mu}", "gain margin").computed == pytest.approx(m * math.pi / 2, rel=1e-9)
    assert reproduction.row(f"mu = {mu}", "phase margin [deg]").computed == pytest.approx(90 - 180 / (math.pi * m), rel=1e-9)


@pytest.mark.parametrize("case", ["P1", "P2"])
@pytest.mark.parametrize("mu", [m for m, _, _ in MU_TABLE])
def test_true_loops_keep_the_gain_margin_bound(reproduction, case, mu):
    # Section 3: the true loops' gain margin exceeds mu (holds for both plants, with N = 10).
    row = reproduction.row(f"true {case} loop, mu = {mu} (extra)", "gain margin")
    assert row.paper is None and row.computed > float(mu)


def test_phase_margin_bound_is_broken_only_by_the_derivative_filter(reproduction):
    # Known discrepancy: with N = 10 the filter's lag puts PM below arccos(1/mu) for P1 (mu = 2, 3)
    # and P2 (mu = 3); the notes say so and that an ideal derivative restores the bound.
    broken = {
        (case, mu)
        for case in ("P1", "P2")
        for mu, _, _ in MU_TABLE
        if reproduction.row(f"true {case} loop, mu = {mu} (extra)", "phase margin [deg]").computed
        <= math.degrees(math.acos(1 / float(mu)))
    }
    assert broken == {("P1", "2"), ("P1", "3"), ("P2", "3")}
    assert any("practically ideal derivative" in note and "hold on every true loop" in note for note in reproduction.notes)
