"""Ingimundarson, Fig. 6: the pairs (gamma, kappa) that fulfil inequality (26), its edge as an upper
limit of kappa against gamma (by bisection), and the design lines gamma kappa <= 1, gamma <= 1 (eq. 27).
The paper prints no numbers on the figure; the closed form derived in the notes is the reference.
"""

import math

import numpy as np
import pytest

from baselines.reproduction.ingimundarson_figures import OMEGA, fig6, inequality_26_sup, kappa_upper_limit


@pytest.fixture(scope="module")
def reproduction():
    return fig6()


@pytest.mark.parametrize("gamma", [0.1, 0.25, 0.5, 1.0, 1.2, math.sqrt(2), 1.5, 1.8, 1.95])
def test_bisection_matches_the_closed_form(gamma):
    # kappa_max = 1/gamma up to sqrt 2, then sqrt(4 - gamma^2)/2; above sqrt 2 the peak is at a finite
    # frequency on the 400-per-decade grid, whose flat top is resolved to ~1e-6.
    expected = 1 / gamma if gamma <= math.sqrt(2) else math.sqrt(4 - gamma**2) / 2
    assert kappa_upper_limit(gamma) == pytest.approx(expected, rel=1e-5)


def test_no_kappa_beyond_gamma_two():
    assert kappa_upper_limit(2.05) == 0.0


@pytest.mark.parametrize("gamma", np.linspace(0.05, 1.0, 20))
def test_design_line_kappa_gamma_one_is_the_edge(gamma):
    # On kappa = 1/gamma the value of (26) stays below 1 at every finite frequency and tends to 1 (Remark after eq. 29).
    s = 1j * OMEGA
    values = np.abs(gamma * OMEGA * (s / gamma + 1) / (s + 1) ** 2)
    assert np.max(values) < 1.0
    assert inequality_26_sup(1 / gamma, gamma) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("kappa", [0.2, 0.5, 1.0])
def test_design_line_gamma_one_is_feasible(kappa):
    assert inequality_26_sup(kappa, 1.0) <= 1.0


def test_rows(reproduction):
    for row in reproduction.rows:
        if row.quantity == "upper limit of kappa (bisection)":
            closed = reproduction.row(row.case, "upper limit of kappa (closed form)")
            assert row.computed == pytest.approx(closed.computed, rel=1e-5)
    assert reproduction.row("gamma = 1, kappa = 1 (both lines)", "sup of (26) (edge: = 1)").computed == pytest.approx(1.0)


def test_figure_is_written(reproduction, tmp_path):
    assert reproduction.figure(tmp_path).stat().st_size > 0
