"""The ``mu`` rules of the Gorez-Klan PID (baselines.rules.mu) against section 3.

The table "Robustness with proposed controller settings" is checked on the exact model loop
``e^{-D_2 s}/(mu D_2 s)`` (eq. 3-12) through ``loop_margins``, to the printed digits (one decimal
for the gain margin, whole degrees for the phase margin); the closed forms of eq. 3-13/3-14 and
their inverses (the margin rules) are checked against the same loop to 1e-9.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from baselines.rules.mu import (
    MU_TABLE,
    gain_margin,
    mu_for_gain_margin,
    mu_for_phase_margin,
    mu_table,
    phase_margin_deg,
)
from envs.analysis.robustness import loop_margins

# Gorez-Klan section 3 table as printed: mu, gain margin, phase margin [deg].
TABLE = [("1.3", "2", "46"), ("1.5", "2.4", "52"), ("2", "3.1", "61"), ("3", "4.7", "71")]


def model_loop_margins(mu: float, dead_time: float = 1.0):
    return loop_margins(lambda w: np.exp(-1j * w * dead_time) / (mu * dead_time * 1j * w), integrators=1, time_scale=dead_time)


def test_table_values_are_the_registry_values():
    assert MU_TABLE == tuple(float(mu) for mu, _, _ in TABLE)
    assert [mu_table(m) for m in MU_TABLE] == list(MU_TABLE)


@pytest.mark.parametrize("mu, gm, pm", TABLE, ids=[f"mu={row[0]}" for row in TABLE])
def test_model_loop_reproduces_the_printed_margins(mu, gm, pm):
    m = model_loop_margins(float(mu))
    # the printed gain margins have one decimal at most ("2" is 2.04), the phase margins none
    assert abs(m.gain_margin - float(gm)) <= 0.05 + 1e-12
    assert abs(m.phase_margin_deg - float(pm)) <= 0.5
    assert f"{m.gain_margin:.1f}".rstrip("0").rstrip(".") == gm
    assert f"{m.phase_margin_deg:.0f}" == pm


@pytest.mark.parametrize("mu", [0.8, *MU_TABLE, 4.0, 8.0])
@pytest.mark.parametrize("dead_time", [0.1, 1.0, 7.0])
def test_closed_forms_match_the_loop(mu, dead_time):
    # eq. 3-13, 3-14: the margins depend on mu alone, not on D_2
    m = model_loop_margins(mu, dead_time)
    assert m.gain_margin == pytest.approx(gain_margin(mu), rel=1e-9)
    assert m.phase_margin_deg == pytest.approx(phase_margin_deg(mu), rel=1e-9)
    assert m.phase_crossover_frequency == pytest.approx(math.pi / (2 * dead_time), rel=1e-9)  # omega_u
    assert m.gain_crossover_frequency == pytest.approx(1 / (mu * dead_time), rel=1e-9)  # omega_co


@pytest.mark.parametrize("mu", [0.7, *MU_TABLE, 5.0])
def test_inverse_rules_round_trip(mu):
    assert mu_for_gain_margin(gain_margin(mu)) == pytest.approx(mu, rel=1e-14)
    assert mu_for_phase_margin(phase_margin_deg(mu)) == pytest.approx(mu, rel=1e-14)


@pytest.mark.parametrize("target", [10.0, 45.0, 60.0, 75.0, 89.0])
def test_phase_margin_rule_meets_its_target_on_the_loop(target):
    assert model_loop_margins(mu_for_phase_margin(target)).phase_margin_deg == pytest.approx(target, rel=1e-9)


@pytest.mark.parametrize("target", [1.2, 2.0, 3.0, 6.0])
def test_gain_margin_rule_meets_its_target_on_the_loop(target):
    assert model_loop_margins(mu_for_gain_margin(target)).gain_margin == pytest.approx(target, rel=1e-9)


def test_registry_targets_coincide():
    # PM = 60 deg and GM = 3 both give mu = 6/pi on the model loop (pi/2 - 1/mu = pi/3 <=> mu pi/2 = 3)
    assert mu_for_phase_margin(60) == pytest.approx(6 / math.pi, rel=1e-15)
    assert mu_for_gain_margin(3) == pytest.approx(6 / math.pi, rel=1e-15)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: mu_for_phase_margin(0.0), "phase_margin_deg must be in \\(0, 90\\)"),
        (lambda: mu_for_phase_margin(90.0), "phase_margin_deg must be in \\(0, 90\\)"),
        (lambda: mu_for_phase_margin(float("nan")), "phase_margin_deg"),
        (lambda: mu_for_gain_margin(1.0), "gain_margin must be > 1"),
        (lambda: mu_for_gain_margin(-2.0), "gain_margin must be > 1"),
        (lambda: mu_table(0.0), "mu"),
        (lambda: mu_table(float("inf")), "mu"),
    ],
    ids=["pm-0", "pm-90", "pm-nan", "gm-1", "gm-negative", "mu-0", "mu-inf"],
)
def test_invalid_targets_are_refused(call, message):
    with pytest.raises(ValueError, match=message):
        call()
