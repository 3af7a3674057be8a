"""Gorez-Klan, "Simple models for process control", section 4: the table of FOPDT parameters
(T_a, D_a, tau) and SOPDT parameters (theta, T_1, T_2, D_2) of P1 (eq. 4-15, alpha = 0.4) and P2
(eq. 4-16, n = 10), computed from the exact moments of the plants.
"""

import pytest

from baselines.reproduction.common import within_rounding
from baselines.reproduction.gorez_klan import MODEL_QUANTITIES, MODEL_TABLE, gorez_klan_models


@pytest.fixture(scope="module")
def reproduction():
    return gorez_klan_models()


@pytest.mark.parametrize("case", sorted(MODEL_TABLE))
@pytest.mark.parametrize("quantity", MODEL_QUANTITIES)
def test_every_printed_value_is_reproduced(reproduction, case, quantity):
    # The paper prints two decimals: the exact moments must round to them (half a unit, 0.005).
    row = reproduction.row(case, quantity)
    assert within_rounding(row), f"{case} {quantity}: {row.computed} vs printed {row.paper}"


@pytest.mark.parametrize("case", sorted(MODEL_TABLE))
def test_models_are_consistent(reproduction, case):
    # Exact identities of eq. 2-5, 2-7 and 2-8 (1e-12: floating point only).
    value = {q: reproduction.row(case, q).computed for q in MODEL_QUANTITIES}
    assert value["T_a"] + value["D_a"] == pytest.approx(1.0, abs=1e-12)  # T_ar = 1 for both plants
    assert value["T_1"] + value["T_2"] + value["D_2"] == pytest.approx(1.0, abs=1e-12)
    theta = value["theta"]
    assert (1 - theta) * (1 + theta**2) ** 0.5 == pytest.approx(1 - value["tau"], abs=1e-12)  # eq. 2-9


def test_figure_is_written(reproduction, tmp_path):
    path = reproduction.figure(tmp_path)
    assert path.exists() and path.stat().st_size > 0
