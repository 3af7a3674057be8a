"""The T_r rules of Ingimundarson (eq. 28, 29, 34, 43, 50), Hagglund's PPI and Matausek-Micic on
hand-computed numbers, and the refusals."""

import math

import pytest

from baselines.rules.dtc import (
    fppi_eq28_29,
    fppi_eq34,
    fppi_kappa_eq34,
    fppi_time_constant,
    msp_eq43,
    msp_eq50,
    msp_matausek_micic,
    msp_time_constant,
    ppi_default,
)
from envs.systems.controllers import FPPI, MSP


@pytest.mark.parametrize(
    "tn, tf, tr",
    [
        (4.0, 1.0, 2.0),  # eq. 28: sqrt(1 * 4) = 2 > 1
        (1.0, 4.0, 4.0),  # eq. 29 active: sqrt(4) = 2 < 4
        (9.0, 0.25, 1.5),  # sqrt(2.25)
        (2.0, 2.0, 2.0),  # both equal
    ],
    ids=["eq28", "eq29", "sqrt", "tie"],
)
def test_fppi_time_constant(tn, tf, tr):
    assert fppi_time_constant(tn, tf) == pytest.approx(tr, rel=1e-15)


def test_fppi_eq28_29_builds_the_controller():
    c = fppi_eq28_29(2.0, 4.0, 3.0, 1.0)
    assert isinstance(c, FPPI)
    assert (c.gain, c.time_constant, c.dead_time, c.tr, c.tf) == (2.0, 4.0, 3.0, 2.0, 2.0)  # T_f = T_r (section 4.3)
    assert c.kappa == 2.0 and c.proportional_gain == pytest.approx(4.0 / (2.0 * 2.0))  # K = T_n/(K_n T_r), eq. 14-15


@pytest.mark.parametrize(
    "tn, tf, dl, kappa",
    [
        (4.0, 0.5, 0.5, 2.0),  # sqrt(4/(0.5+0.5)) = 2
        (10.4, 0.27, 0.0, math.sqrt(10.4 / 0.27)),  # Table 1, P1: 6.21 (the printed eq. 34 would give 0.16)
        (1.0, 1.5, 0.5, 0.5),  # eq. 29 active: T_r = 2, kappa = 1/2
    ],
)
def test_kappa_eq34(tn, tf, dl, kappa):
    assert fppi_kappa_eq34(tn, tf, dl) == pytest.approx(kappa, rel=1e-14)


def test_fppi_eq34_adds_the_dead_time_error_to_the_mismatch():
    c = fppi_eq34(1.0, 8.0, 5.0, 0.1, 1.9)  # sqrt((0.1 + 1.9) 8) = 4
    assert c.tr == pytest.approx(4.0) and c.tf == c.tr and c.kappa == pytest.approx(2.0)
    assert c.tr == pytest.approx(fppi_eq28_29(1.0, 8.0, 5.0, 2.0).tr)


def test_ppi_default_is_kappa_one():
    c = ppi_default(1.5, 7.0, 2.0)
    assert c.tr == 7.0 and c.kappa == 1.0 and c.tf == 7.0
    assert ppi_default(1.5, 7.0, 2.0, filtered=False).tf == 0.0


@pytest.mark.parametrize(
    "gain, ln, beta, tr",
    [
        (1.0, 6.0, 0.4, 2 * 6 * 0.4 / 5.6),  # Table 2, P1 with the printed A
        (1.0, 10.0, 5.0, 20.0),  # beta = K L/2 gives T_r = 2 L
        (2.0, 5.0, 2.0, 2 * 5 * 2 / (10 - 2)),  # K_n = 2
        (-2.0, 5.0, 2.0, 2.5),  # a negative gain uses |K_n|
    ],
)
def test_msp_time_constant_eq43(gain, ln, beta, tr):
    assert msp_time_constant(gain, ln, beta) == pytest.approx(tr, rel=1e-14)


def test_eq43_inverts_eq42():
    # beta = K_n L_n T_r/(2 L_n + T_r) (eq. 42) for the T_r of eq. 43.
    k, ln, beta = 0.7, 8.0, 1.3
    tr = msp_time_constant(k, ln, beta)
    assert k * ln * tr / (2 * ln + tr) == pytest.approx(beta, rel=1e-14)


@pytest.mark.parametrize("beta", [6.0, 7.5])
def test_msp_refuses_beta_at_or_above_kn_ln(beta):
    with pytest.raises(ValueError, match=r"beta = .* >= \|K_n\| L_n = 6: eq. 43 has no positive T_r"):
        msp_time_constant(1.0, 6.0, beta)
    with pytest.raises(ValueError, match="eq. 43 has no positive T_r"):
        msp_eq43(1.0, 6.0, beta)


def test_msp_eq43_with_a_dead_time_error():
    # beta = A + K_n Delta L (section 5.2): 0.5 + 2 * 0.25 = 1, L_n = 4: T_r = 2*4*1/(8 - 1)
    c = msp_eq43(2.0, 4.0, 0.5, 0.25)
    assert isinstance(c, MSP) and c.tr == pytest.approx(8.0 / 7.0)
    assert c.kr == pytest.approx(1 / (2.0 * c.tr)) and c.k0 == pytest.approx(1 / (2 * 4.0 * 2.0))  # eq. 36, 38


@pytest.mark.parametrize("delta, ratio", [(0.2, 0.5), (0.5, 2.0), (1 / 3, 1.0)])
def test_msp_eq50(delta, ratio):
    assert msp_eq50(1.0, 10.0, delta).tr == pytest.approx(10.0 * ratio)
    # eq. 50 is eq. 43 with beta = Delta L K_n.
    assert msp_eq50(3.0, 10.0, delta).tr == pytest.approx(msp_time_constant(3.0, 10.0, 3.0 * 10.0 * delta))


@pytest.mark.parametrize("delta", [0.0, 1.0, 1.5, -0.2])
def test_msp_eq50_refuses_delta_outside_zero_one(delta):
    with pytest.raises(ValueError, match="relative_dead_time_error must be in"):
        msp_eq50(1.0, 10.0, delta)


def test_matausek_micic_and_extension():
    c = msp_matausek_micic(1.0, 8.0, 2.0, extension=True)
    assert c.tr == 2.0 and c.extension and c.k0 == pytest.approx(0.6 / 8.0)  # eq. 51


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: fppi_time_constant(0.0, 1.0), "time_constant must be > 0"),
        (lambda: fppi_time_constant(1.0, float("nan")), "mismatch_time must be finite"),
        (lambda: fppi_kappa_eq34(1.0, 0.0, 0.0), "mismatch_time \\+ dead_time_error must be > 0"),
        (lambda: fppi_eq34(1.0, 1.0, 1.0, 0.1, -0.1), "dead_time_error must be >= 0"),
        (lambda: msp_time_constant(0.0, 1.0, 0.1), "gain must be non-zero"),
        (lambda: msp_time_constant(1.0, 1.0, 0.0), "beta must be > 0"),
        (lambda: msp_eq43(1.0, 5.0, True), "pulse_area must be a number"),
    ],
)
def test_invalid_inputs_are_refused_with_the_field_named(call, message):
    with pytest.raises(ValueError, match=message):
        call()
