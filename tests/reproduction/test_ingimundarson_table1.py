"""Ingimundarson, Table 1 (section 4.4): T_n, L_n, T_f_bar, T_r and kappa of the FPPI design for the
seven stable processes P_i(s) e^{-5s}, by the paper's procedure (closed-loop moments eq. 10,
open-loop step eq. 11 and 22, design eq. 28/29).

Most printed values are NOT reproduced, for reasons found and written in the notes: the paper's
T_ar was not the exact one (T_n + L_n differs from -p1 by up to 10%), its T_n column follows the
ramp formula eq. 12 rather than eq. 11 for several processes, and its T_f_bar cannot be obtained
even from its own printed model.  The tests pin both what reproduces and what does not, so that
a change in either direction is noticed.
"""

import pytest

from baselines.reproduction.common import within_rounding
from baselines.reproduction.ingimundarson_tables import (
    PAPER_INPUTS_KAPPA,
    PAPER_INPUTS_TR,
    PAPER_MODEL_TF,
    TABLE1,
    table1,
)

CASES = sorted(TABLE1)
# Printed values reproduced to half a unit of their last printed decimal, per column.
REPRODUCED = {
    "T_n (eq. 11)": {"P5"},
    # L_n matches T_ar - T_n(eq. 11) where the paper's T_n does not: its columns come from different models.
    "L_n": {"P1", "P2", "P5", "P7"},
    "T_f_bar (eq. 22)": set(),
    "T_r (eq. 28/29)": {"P2", "P6"},
    "kappa": {"P6"},
    # The paper's T_n + L_n differs from the exact T_ar (17, 8, 11, 10, 6.22, 10.5, 6.875) except for P5.
    "T_n + L_n = T_ar (eq. 10) (extra)": {"P5"},
    # The ramp formula eq. 12 gives the printed T_n for these four (eq. 11 only for P5).
    "T_n by eq. 12, ramp (extra)": {"P1", "P2", "P5", "P7"},
    # Even the paper's own (T_n, L_n) model does not give its printed T_f_bar.
    PAPER_MODEL_TF: set(),
    # The rule eq. 28/29 applied to the paper's own T_n, T_f_bar gives its T_r everywhere ...
    PAPER_INPUTS_TR: set(CASES),
    # ... and its kappa except P5 (a slip, outside what input rounding allows) and P7 (2.77 vs 2.7,
    # inside what the rounding of the printed T_n = 1.3, T_f_bar = 0.17 allows).
    PAPER_INPUTS_KAPPA: set(CASES) - {"P5", "P7"},
}


@pytest.fixture(scope="module")
def reproduction():
    return table1()


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("quantity", sorted(REPRODUCED))
def test_rows_reproduce_exactly_where_expected(reproduction, case, quantity):
    row = reproduction.row(case, quantity)
    expected = case in REPRODUCED[quantity]
    assert within_rounding(row) == expected, f"{case} {quantity}: computed {row.computed:.4f}, printed {row.paper}"


@pytest.mark.parametrize("case", CASES)
def test_procedure_is_internally_consistent(reproduction, case):
    # L_n = T_ar - T_n and kappa = T_n/T_r by construction; T_r = max(sqrt(T_f T_n), T_f) (eq. 28/29).
    value = {q: reproduction.row(case, q).computed for q in REPRODUCED}
    assert value["L_n"] + value["T_n (eq. 11)"] == pytest.approx(value["T_n + L_n = T_ar (eq. 10) (extra)"], rel=1e-12)
    assert value["kappa"] == pytest.approx(value["T_n (eq. 11)"] / value["T_r (eq. 28/29)"], rel=1e-12)
    expected = max((value["T_f_bar (eq. 22)"] * value["T_n (eq. 11)"]) ** 0.5, value["T_f_bar (eq. 22)"])
    assert value["T_r (eq. 28/29)"] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("case, exact", [("P1", 17.0), ("P2", 8.0), ("P3", 11.0), ("P4", 10.0), ("P5", 56 / 9), ("P6", 10.5), ("P7", 6.875)])
def test_closed_loop_moments_recover_the_exact_residence_time(reproduction, case, exact):
    # eq. 10 on the noise-free closed-loop step: sampling and the steady-state cut leave ~1e-4 relative.
    assert reproduction.row(case, "T_n + L_n = T_ar (eq. 10) (extra)").computed == pytest.approx(exact, rel=2e-4)


def test_notes_name_the_slip_in_kappa_of_p5(reproduction):
    assert any("P5: the printed T_n = 0.8, T_f_bar = 0.17 allow kappa" in note for note in reproduction.notes)
