"""Analytic PI/PID rules (:mod:`baselines.rules.pid`, :mod:`baselines.rules.pid_registry`).

Reference values:

* Marlin, *Process Control* (seed 001): Table 10.4 (Ziegler-Nichols closed loop), Table 10.5
  (open loop), Examples 10.10, 10.12, 10.13 (ultimate point and Ziegler-Nichols tunings).  The
  OCR lines are quoted next to the numbers.  Marlin reads the critical frequency and amplitude
  ratio off a coarse table or a Bode plot and prints 2-3 digits, so his values are compared with
  the exact ones at a relative tolerance of 2.5 % (his largest deviation, Example 10.12 with
  ``n = 3``, is 2.3 %: he read ``AR = 0.122`` for the exact ``1/8``).
* The other rules: hand computations from the formulas on round models, the arithmetic written
  next to each row (``a = K L/T``), and exact properties of the designed loops (Haalman's
  ``2 e^{-Ls}/(3Ls)``, SIMC's ``e^{-theta s}/(2 theta s)``) that the sources state.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from baselines.rules import pid as rules
from baselines.rules.pid_registry import RULES, PIDFormula
from envs.analysis.loop_analysis import plant_margins
from envs.systems.controllers import PID, SeriesPID
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.systems.plants import Plant

FOPDT = FOPDTModel(gain=2.0, time_constant=10.0, dead_time=2.0)  # a = K L/T = 0.4, L/T = 0.2
INTEGRATING = IntegratingModel(gain=0.5, dead_time=2.0)  # a = K_v L = 1
INTEGRATING_LAG = IntegratingModel(gain=0.5, dead_time=2.0, time_constant=3.0)
SKOGESTAD_SOPDT = SOPDTModel(gain=1.0, time_constants=(6.0, 2.5), dead_time=1.0)  # e^{-s}/((6s+1)(2.5s+1))
OMEGA = np.array([1e-3, 0.1, 0.7, 1.0, 3.0, 50.0])


def params(controller: PID | SeriesPID) -> tuple[float, float, float]:
    return controller.kp, controller.ti, controller.td


# --------------------------------------------------------------------------- forms
SERIES_CASES = [(1.0, 10.0, 2.5), (-3.2, 0.7, 0.7), (0.05, 1e3, 1e-2), (7.0, 4.0, 0.0), (2.0, 1.0, 5.0)]


def unfiltered_ideal(kp, ti, td, omega):
    s = 1j * omega
    return kp * (1 + 1 / (ti * s) + td * s)


def unfiltered_series(kp, ti, td, omega):
    s = 1j * omega
    return kp * (1 + 1 / (ti * s)) * (1 + td * s)


@pytest.mark.parametrize("kp, ti, td", SERIES_CASES)
def test_series_ideal_round_trip(kp, ti, td):
    ideal = rules.series_to_ideal(kp, ti, td)
    assert ideal[1] >= 4 * ideal[2]
    # ideal_to_series takes the larger root as integral time; a series pair with ti < td comes
    # back swapped, with kp_s = kp' ti_s/ti' = kp max(ti, td)/ti
    expected = (kp * max(ti, td) / ti, max(ti, td), min(ti, td)) if td > 0 else (kp, ti, td)
    np.testing.assert_allclose(rules.ideal_to_series(*ideal), expected, rtol=1e-12)


@pytest.mark.parametrize("kp, ti, td", [(1.0, 10.0, 1.0), (-2.0, 4.0, 1.0), (0.3, 9.0, 0.0), (5.0, 1.0, 0.2499)])
def test_ideal_series_round_trip(kp, ti, td):
    np.testing.assert_allclose(rules.series_to_ideal(*rules.ideal_to_series(kp, ti, td)), (kp, ti, td), rtol=1e-12)


@pytest.mark.parametrize("kp, ti, td", SERIES_CASES)
def test_conversion_gives_equal_unfiltered_transfer_functions(kp, ti, td):
    series = unfiltered_series(kp, ti, td, OMEGA)
    ideal = unfiltered_ideal(*rules.series_to_ideal(kp, ti, td), OMEGA)
    np.testing.assert_allclose(ideal, series, rtol=1e-13)


def test_filtered_forms_are_not_equivalent():
    # why series rules return SeriesPID: with the derivative filter the exact conversion fails
    kp, ti, td = 1.0, 10.0, 2.5
    series = SeriesPID(kp, ti, td, n=10).feedback_response(OMEGA)
    ideal = PID(*rules.series_to_ideal(kp, ti, td), n=10).feedback_response(OMEGA)
    assert np.max(np.abs(ideal / series - 1)) > 0.01


def test_ideal_to_series_needs_real_zeros():
    assert rules.ideal_to_series(2.0, 4.0, 1.0) == pytest.approx((1.0, 2.0, 2.0), rel=1e-15)  # double zero
    with pytest.raises(ValueError, match="ti >= 4 td"):
        rules.ideal_to_series(1.0, 3.9, 1.0)
    with pytest.raises(ValueError, match="ti must be"):
        rules.series_to_ideal(1.0, 0.0, 1.0)


# --------------------------------------------------------------------------- ultimate point
def test_ultimate_point_marlin_example_10_10():
    # Marlin Example 10.10, Gp = 0.039/(5s+1)^3: "Pu = 2jt/coc = 17.9 min and Ku = 1/ARC = 208",
    # read at "0.35 ... 180.8 (critical frequency) ... 0.0048".  Exact: -3 atan(5 w) = -pi gives
    # w_u = tan(pi/3)/5 and |G| = 0.039/(1 + 3)^(3/2) = 0.039/8.
    point = rules.ultimate_point(Plant.from_time_constants(0.039, [5.0, 5.0, 5.0]))
    assert point.frequency == pytest.approx(math.sqrt(3) / 5, rel=1e-12)
    assert point.gain == pytest.approx(8 / 0.039, rel=1e-12)
    assert point.gain == pytest.approx(208, rel=0.025)
    assert point.period == pytest.approx(17.9, rel=0.025)


@pytest.mark.parametrize(
    "order, omega_c, ratio, kc, ti",
    [
        # Marlin Example 10.12, n first-order lags K = 1, tau = 5, ZN PI; OCR table:
        # "1 3 5 7 / 00 — oo — / 0.35 0.145 0.096 / 0.122 0.348 0.484 / 3.72 1.31 0.94 / 15.0 36.1 54.5"
        (3, 0.35, 0.122, 3.72, 15.0),
        (5, 0.145, 0.348, 1.31, 36.1),
        (7, 0.096, 0.484, 0.94, 54.5),
    ],
)
def test_ultimate_point_and_zn_pi_marlin_example_10_12(order, omega_c, ratio, kc, ti):
    plant = Plant.from_time_constants(1.0, [5.0] * order)
    point = rules.ultimate_point(plant)
    # exact: n atan(5 w) = pi, |G| = cos(pi/n)^n
    assert point.frequency == pytest.approx(math.tan(math.pi / order) / 5, rel=1e-12)
    assert 1 / point.gain == pytest.approx(math.cos(math.pi / order) ** order, rel=1e-12)
    assert point.frequency == pytest.approx(omega_c, rel=0.025)
    assert 1 / point.gain == pytest.approx(ratio, rel=0.025)
    controller = rules.zn_ultimate_pi(*point)
    assert controller.kp == pytest.approx(kc, rel=0.025)
    assert controller.ti == pytest.approx(ti, rel=0.025)


@pytest.mark.parametrize(
    "model, omega_c, ratio, ku, pu, kc, ti, td",
    [
        # Marlin Example 10.13, ZN PID; OCR: "Plant A ... 0.86 0.144 6.94 7.3 4.1 3.65 0.91" for
        # Kp = 1, tau = 8, theta = 2, and "Plant B ... 0.32 0.84 ... 1.19 19.60 0.70 9.8 2.45" for
        # Kp = 1, tau = 2, theta = 8 (columns wc, ARc, Ku, Pu, Kc, Ti, Td).
        pytest.param(FOPDTModel(1.0, 8.0, 2.0), 0.86, 0.144, 6.94, 7.3, 4.1, 3.65, 0.91, id="plant-A"),
        pytest.param(FOPDTModel(1.0, 2.0, 8.0), 0.32, 0.84, 1.19, 19.6, 0.70, 9.8, 2.45, id="plant-B"),
    ],
)
def test_zn_ultimate_pid_marlin_example_10_13(model, omega_c, ratio, ku, pu, kc, ti, td):
    point = rules.ultimate_point(model)
    w = point.frequency
    assert math.atan(model.time_constant * w) + model.dead_time * w == pytest.approx(math.pi, rel=1e-13)
    assert point.gain == pytest.approx(math.hypot(1.0, model.time_constant * w), rel=1e-13)
    for computed, printed in [(w, omega_c), (1 / point.gain, ratio), (point.gain, ku), (point.period, pu)]:
        assert computed == pytest.approx(printed, rel=0.025)
    assert params(rules.zn_ultimate_pid(*point)) == pytest.approx((kc, ti, td), rel=0.025)


def test_zn_ultimate_table_10_4_arithmetic():
    # Marlin Table 10.4, OCR "Ponly Ku/2 KJ2.2 KJl.l — PI PID /yi.2 P„/2.0 Td PM/8": PI Ku/2.2,
    # Pu/1.2; PID Ku/1.7 (OCR "KJl.l"), Pu/2.0, Pu/8.  Example 10.10 applies it to Ku = 208,
    # Pu = 17.9 and prints "PI PID 104 94.5 122.4 14.9 8.95 2.2": equal to half a unit in the
    # last printed digit.
    pi = rules.zn_ultimate_pi(208.0, 17.9)
    pid = rules.zn_ultimate_pid(208.0, 17.9)
    assert pi.kp == pytest.approx(94.5, abs=0.05) and pi.ti == pytest.approx(14.9, abs=0.05)
    assert pid.kp == pytest.approx(122.4, abs=0.05) and pid.ti == pytest.approx(8.95, abs=0.005)
    assert pid.td == pytest.approx(2.2, abs=0.05) and pid.ti == 4 * pid.td


def test_ultimate_point_integrating_and_sign():
    # K_v e^{-Ls}/s: -pi/2 - w L = -pi, so w_u = pi/(2L) and K_u = w_u/K_v
    point = rules.ultimate_point(INTEGRATING)
    assert point.frequency == pytest.approx(math.pi / 4, rel=1e-13)
    assert point.gain == pytest.approx(math.pi / 4 / 0.5, rel=1e-13)
    negative = rules.ultimate_point(FOPDTModel(-2.0, 10.0, 2.0))
    positive = rules.ultimate_point(FOPDT)
    assert negative.gain == pytest.approx(-positive.gain, rel=1e-14)
    assert negative.period == pytest.approx(positive.period, rel=1e-14)
    plant = FOPDTModel(-2.0, 10.0, 2.0).plant()
    assert complex(plant.frequency_response(negative.frequency)) * negative.gain == pytest.approx(-1, abs=1e-12)


@pytest.mark.parametrize(
    "plant",
    [
        Plant.from_time_constants(1.0, [1.0, 1.0, 1.0], 0.5, zero_time_constants=[-2.0]),  # RHP zero
        Plant(num=(1.0,), den=(1.0, 0.4, 1.0), dead_time=0.3),  # underdamped pair
        Plant.from_time_constants(3.0, [2.0], 1.0, zero_time_constants=[0.5], integrating=True),
    ],
)
def test_ultimate_point_against_unwrapped_phase(plant):
    # an independent phase: np.unwrap on a dense grid starting near w = 0
    omega = np.logspace(-5, 2, 400_001)
    phase = np.unwrap(np.angle(plant.frequency_response(omega) * np.sign(plant.gain)))
    first = np.flatnonzero(phase <= -math.pi)[0]
    point = rules.ultimate_point(plant)
    assert point.frequency == pytest.approx(omega[first], rel=1e-4)
    assert complex(plant.frequency_response(point.frequency)) * point.gain == pytest.approx(-1, abs=1e-10)


def test_ultimate_point_without_crossover():
    with pytest.raises(ValueError, match="never reaches -180"):
        rules.ultimate_point(FOPDTModel(1.0, 5.0, 0.0))


# --------------------------------------------------------------------------- reference values
REFERENCE = [
    # Ziegler-Nichols reaction curve, Marlin Table 10.5, OCR "(\/Kp)/(z/9) (0.9/Kp)(z/9)
    # (1.2/Kp)(z/9)" and "3.39 — 2.09 0.59" (T_i = 3.3 theta, 2.0 theta, T_d = 0.5 theta).
    # FOPDT K=2, T=10, L=2: a = 0.4; PI 0.9/0.4 = 2.25, 3.3*2 = 6.6; PID 1.2/0.4 = 3, 4, 1
    ("zn-step-pi", FOPDT, (2.25, 6.6, 0.0)),
    ("zn-step-pid", FOPDT, (3.0, 4.0, 1.0)),
    # integrating with lag: ramp asymptote 0.5 (t - 5), L_a = 2 + 3 = 5, a = 0.5*5 = 2.5
    ("zn-step-pi", INTEGRATING_LAG, (0.9 / 2.5, 16.5, 0.0)),
    ("zn-step-pid", INTEGRATING, (1.2, 4.0, 1.0)),
    # Cohen-Coon, r = L/T = 0.2: PI (T/(KL))(0.9 + r/12) = 2.5*0.91667 = 2.291667,
    # T_i = 2 (30 + 0.6)/(9 + 4) = 4.707692; PID 2.5 (4/3 + 0.05) = 3.458333,
    # T_i = 2 (32 + 1.2)/(13 + 1.6) = 4.547945, T_d = 8/(11 + 0.4) = 0.701754
    ("cohen-coon-pi", FOPDT, (2.2916667, 4.7076923, 0.0)),
    ("cohen-coon-pid", FOPDT, (3.4583333, 4.5479452, 0.7017544)),
    # Chien-Hrones-Reswick, a = 0.4, T = 10, L = 2
    ("chr-setpoint-0-pi", FOPDT, (0.35 / 0.4, 12.0, 0.0)),
    ("chr-setpoint-20-pi", FOPDT, (0.6 / 0.4, 10.0, 0.0)),
    ("chr-load-0-pi", FOPDT, (0.6 / 0.4, 8.0, 0.0)),
    ("chr-load-20-pi", FOPDT, (0.7 / 0.4, 4.6, 0.0)),
    ("chr-setpoint-0-pid", FOPDT, (0.6 / 0.4, 10.0, 1.0)),
    ("chr-setpoint-20-pid", FOPDT, (0.95 / 0.4, 14.0, 0.94)),
    ("chr-load-0-pid", FOPDT, (0.95 / 0.4, 4.8, 0.84)),
    ("chr-load-20-pid", FOPDT, (1.2 / 0.4, 4.0, 0.84)),
    ("chr-load-20-pid", INTEGRATING, (1.2, 4.0, 0.84)),  # a = 1, L = 2
    # Haalman on K=2, T1=10, T2=3, L=2: K_c = 2*10/(3*2*2) = 5/3
    ("haalman-pid", SOPDTModel(2.0, (10.0, 3.0), 2.0), (5.0 / 3.0, 10.0, 3.0)),
    ("haalman-pid", FOPDT, (5.0 / 3.0, 10.0, 0.0)),  # Haalman's PI
    # AMIGO PI: 0.15/2 + (0.35 - 20/144)*10/4 = 0.075 + 0.527778 = 0.602778,
    # T_i = 0.7 + 13*2*100/(100 + 240 + 28) = 0.7 + 7.065217 = 7.765217
    ("amigo-pi", FOPDT, (0.6027778, 7.7652174, 0.0)),
    # AMIGO PID: (0.2 + 0.45*5)/2 = 1.225, T_i = 2 (0.8 + 8)/(2 + 1) = 5.866667,
    # T_d = 0.5*2*10/(0.6 + 10) = 0.943396
    ("amigo-pid", FOPDT, (1.225, 5.8666667, 0.9433962)),
    # AMIGO integrating ([AH06]): 0.35/(K_v L) = 0.35, 13.4 L; 0.45/(K_v L), 8 L, 0.5 L
    ("amigo-pi", INTEGRATING, (0.35, 26.8, 0.0)),
    ("amigo-pid", INTEGRATING, (0.45, 16.0, 1.0)),
    # SIMC, tau_c = theta = 2: K_c = 10/(2*4) = 1.25, tau_I = min(10, 16)
    ("simc-pi", FOPDT, (1.25, 10.0, 0.0)),
    # SIMC on e^{-s}/((6s+1)(2.5s+1)): PID (series) 6/(1*2) = 3, min(6, 8) = 6, tau_D = 2.5
    # (the PI via the half rule is test_simc_pi_half_rule)
    ("simc-pid", SKOGESTAD_SOPDT, (3.0, 6.0, 2.5)),
    # SIMC integrating: 1/(0.5*(2 + 2)) = 0.5, 4*4 = 16; with lag 3: PID tau_D = 3; PI half
    # rule theta = 2 + 1.5: 1/(0.5*7), 4*7 = 28
    ("simc-pi", INTEGRATING, (0.5, 16.0, 0.0)),
    ("simc-pid", INTEGRATING_LAG, (0.5, 16.0, 3.0)),
    ("simc-pi", INTEGRATING_LAG, (1 / 3.5, 28.0, 0.0)),
    # improved SIMC: tau_1 + theta/3 = 10.6667, K_c = 10.6667/(2*4), tau_I = min(10.6667, 16)
    ("isimc-pi", FOPDT, ((10.0 + 2 / 3) / 8.0, 10.0 + 2 / 3, 0.0)),
    # pure dead time e^{-s}: K_c = (1/3)/(1*2) = 1/6, tau_I = 1/3 ([GS] section 5: "0.17/k",
    # "0.33 theta"), where SIMC gives integral-only control
    ("isimc-pi", FOPDTModel(1.0, 0.0, 1.0), (1 / 6, 1 / 3, 0.0)),
    # IMC PI ([RMS] improved PI), lambda = 1.7*2 = 3.4: (20 + 2)/(2*2*3.4) = 1.617647, 10 + 1
    ("imc-pi", FOPDT, (22 / 13.6, 11.0, 0.0)),
    # IMC PID, lambda = 0.8*2 = 1.6: 22/(2*(3.2 + 2)) = 2.115385, 11, 10*2/22 = 0.909091
    ("imc-pid", FOPDT, (22 / 10.4, 11.0, 20 / 22)),
    # IMC PI integrating ([CF]), lambda = 3.4: (6.8 + 2)/(0.5*5.4^2) = 0.603567, 8.8
    ("imc-pi", INTEGRATING, (8.8 / (0.5 * 5.4**2), 8.8, 0.0)),
]


REFERENCE_IDS = [f"{name}-{type(model).__name__}" for name, model, _ in REFERENCE]


@pytest.mark.parametrize("name, model, expected", REFERENCE, ids=REFERENCE_IDS)
def test_reference_values(name, model, expected):
    controller = RULES[name].design(model)
    assert isinstance(controller, SeriesPID if RULES[name].form == "series" else PID)
    assert params(controller) == pytest.approx(expected, rel=1e-7, abs=1e-12)
    if controller.td > 0:
        assert controller.n == rules.DERIVATIVE_FILTER


def test_reaction_curve_rules_scale_with_gain_sign_and_time():
    # a = K L/T is invariant to the time scale; K_c scales with 1/K (sign included), times with L
    base = RULES["chr-load-0-pid"].design(FOPDT)
    scaled = RULES["chr-load-0-pid"].design(FOPDTModel(-4.0, 1000.0, 200.0))
    assert params(scaled) == pytest.approx((-base.kp / 2, 100 * base.ti, 100 * base.td), rel=1e-12)


def test_amigo_integrating_is_the_fopdt_limit():
    # [AH04]: the integrating PID rules are the T -> infinity limits with K = K_v T
    big = 1e7
    limit = rules.amigo_pid(FOPDTModel(0.5 * big, big, 2.0))
    assert params(limit) == pytest.approx(params(rules.amigo_pid(INTEGRATING)), rel=1e-5)
    # the PI limit is T_i = 13.35 L, which [AH06] round to 13.4 L
    assert rules.amigo_pi(FOPDTModel(0.5 * big, big, 2.0)).ti == pytest.approx(13.35 * 2.0, rel=1e-5)


def test_imc_pid_is_the_series_pade_design():
    # IMC with the first-order Pade gives the series PID T/(K(lambda + L/2)) (1 + 1/(T s))(1 + L s/2)
    lam = 1.6
    series = (10.0 / (2.0 * (lam + 1.0)), 10.0, 1.0)
    assert params(rules.imc_pid(FOPDT, lam=lam)) == pytest.approx(rules.series_to_ideal(*series), rel=1e-14)


def test_imc_integrating_derivation():
    # [CF]: G = K_v (1 - L s)/s, q = s ((2 lam + L) s + 1)/(K_v (lam s + 1)^2), C = q/(1 - G q)
    kv, dead, lam = 0.5, 2.0, 3.4
    s = 1j * OMEGA
    g = kv * (1 - dead * s) / s
    q = s * ((2 * lam + dead) * s + 1) / (kv * (lam * s + 1) ** 2)
    imc = q / (1 - g * q)
    np.testing.assert_allclose(rules.imc_pi(INTEGRATING, lam=lam).feedback_response(OMEGA), imc, rtol=1e-9)


def test_haalman_loop_is_two_thirds_over_ls():
    # [HA]: the series PID cancels both lags, C G = 2 e^{-Ls}/(3 L s) up to the derivative filter
    model = SOPDTModel(2.0, (10.0, 3.0), 2.0)
    controller = rules.haalman_pid(model)
    s = 1j * OMEGA
    target = 2 * np.exp(-2.0 * s) / (3 * 2.0 * s) / (1 + 3.0 * s / controller.n)
    loop = controller.feedback_response(OMEGA) * model.plant().frequency_response(OMEGA)
    np.testing.assert_allclose(loop, target, rtol=1e-12)
    # with a negligible filter: gain margin 3 pi/4 (phase -pi at w L = pi/2), phase margin
    # pi/2 - 2/3 rad = 51.8 deg, and Ms 1.92 (the figure usually quoted for Haalman's loop is 1.9)
    margins = plant_margins(model.plant(), rules.haalman_pid(model, n=1e6))
    assert margins.gain_margin == pytest.approx(3 * math.pi / 4, rel=1e-5)
    assert margins.phase_margin_deg == pytest.approx(90 - math.degrees(2 / 3), rel=1e-5)
    assert margins.ms == pytest.approx(1.92, abs=0.005)


def test_simc_loop_margins():
    # [SK], tau_c = theta, tau_1 <= 8 theta: loop e^{-theta s}/(2 theta s); GM = pi (3.14),
    # PM = pi/2 - 1/2 rad (61.4 deg), delay margin (pi - 1) theta (2.14 theta), Ms 1.59
    margins = plant_margins(FOPDT.plant(), rules.simc_pi(FOPDT))
    assert margins.gain_margin == pytest.approx(math.pi, rel=1e-9)
    assert margins.phase_margin_deg == pytest.approx(90 - math.degrees(0.5), rel=1e-9)
    assert margins.delay_margin == pytest.approx((math.pi - 1) * 2.0, rel=1e-9)
    x = np.linspace(0.01, 3.0, 300_001)  # independent Ms: 1/min |1 + e^{-ix}/(2ix)|
    assert margins.ms == pytest.approx(1 / np.min(np.abs(1 + np.exp(-1j * x) / (2j * x))), rel=1e-6)
    assert margins.ms == pytest.approx(1.59, abs=0.005)


def test_simc_pi_half_rule():
    # [SK] half rule on e^{-s}/((6s+1)(2.5s+1)): theta = 1 + 2.5/2, tau_1 = 6 + 2.5/2; then
    # K_c = 7.25/(1*(2.25 + 2.25)) = 1.611111, tau_I = min(7.25, 4*4.5)
    assert rules.half_rule(SOPDTModel(1.0, (2.5, 6.0), 1.0)) == FOPDTModel(1.0, 7.25, 2.25)
    assert params(rules.simc_pi(SKOGESTAD_SOPDT)) == pytest.approx((7.25 / 4.5, 7.25, 0.0), rel=1e-14)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: rules.zn_step_pi(FOPDTModel(1.0, 5.0, 0.0)), "dead_time > 0"),
        (lambda: rules.cohen_coon_pi(INTEGRATING), "needs a FOPDTModel"),
        (lambda: rules.chr_pi(INTEGRATING, objective="setpoint"), "integrating"),
        (lambda: rules.chr_pid(FOPDT, objective="load", overshoot=10), "overshoot"),
        (lambda: rules.simc_pi(FOPDTModel(1.0, 0.0, 1.0)), "isimc_pi"),
        (lambda: rules.imc_pid(FOPDTModel(1.0, 5.0, 0.0)), "imc_pid needs dead_time > 0 \\(its default lambda is 0.8 times the dead time\\), got 0.0"),
        (lambda: rules.zn_ultimate_pi(1.0, -2.0), "ultimate_period"),
        (lambda: RULES["imc-pid"].design(INTEGRATING), "needs one of FOPDTModel"),
        (lambda: RULES["haalman-pid"].design(INTEGRATING), "needs one of"),
    ],
)
def test_invalid_input_is_refused(call, message):
    with pytest.raises(ValueError, match=message):
        call()


# --------------------------------------------------------------------------- registry
EXPECTED_NAMES = {
    "zn-step-pi", "zn-step-pid", "zn-ultimate-pi", "zn-ultimate-pid", "cohen-coon-pi", "cohen-coon-pid",
    *(f"chr-{o}-{p}-{k}" for o in ("setpoint", "load") for p in (0, 20) for k in ("pi", "pid")),
    "haalman-pid", "amigo-pi", "amigo-pid", "simc-pi", "simc-pid", "isimc-pi", "imc-pi", "imc-pid",
}  # fmt: skip


def test_registry_names_and_fields():
    assert set(RULES) == EXPECTED_NAMES
    for name, spec in RULES.items():
        assert isinstance(spec, PIDFormula) and spec.name == name
        assert spec.model in ("fopdt", "sopdt", "ultimate") and spec.form in ("ideal", "series")
        assert len(spec.citation) > 10


@pytest.mark.parametrize("name", sorted(EXPECTED_NAMES))
def test_registry_integrating_flag_matches_behaviour(name):
    spec = RULES[name]
    if spec.integrating:
        controller = spec.design(INTEGRATING_LAG)
        assert controller.integrators == 1
        assert plant_margins(INTEGRATING_LAG.plant(), controller).stable
    else:
        with pytest.raises(ValueError):
            spec.design(INTEGRATING_LAG)


# --------------------------------------------------------------------------- nominal stability
NORMALIZED_DEAD_TIMES = (0.1, 0.3, 0.5, 0.7)


@pytest.mark.parametrize("tau", NORMALIZED_DEAD_TIMES)
@pytest.mark.parametrize("name", sorted(EXPECTED_NAMES))
def test_stable_on_nominal_fopdt(name, tau):
    # K = 1, T_ar = L + T = 1, tau = L/T_ar; the SOPDT rules see T2 = 0 (Haalman's and SIMC's PI)
    model = FOPDTModel(1.0, 1.0 - tau, tau)
    plant = Plant.from_time_constants(1.0, [1.0 - tau], tau)
    assert plant_margins(plant, RULES[name].design(model)).stable


@pytest.mark.parametrize("name", ["haalman-pid", "simc-pid", "zn-ultimate-pid"])
@pytest.mark.parametrize("tau", NORMALIZED_DEAD_TIMES)
def test_stable_on_nominal_sopdt(name, tau):
    model = SOPDTModel(1.0, (0.8 * (1 - tau), 0.2 * (1 - tau)), tau)
    assert plant_margins(model.plant(), RULES[name].design(model)).stable


@pytest.mark.parametrize("name", ["zn-step-pid", "simc-pi", "amigo-pid"])
def test_negative_gain_and_time_scale(name):
    # reverse action: a negative process gain gives a negative kp and the same stable loop
    model = FOPDTModel(-3.0, 35.0, 15.0)
    controller = RULES[name].design(model)
    assert controller.kp < 0
    assert plant_margins(model.plant(), controller).stable


@pytest.mark.parametrize("tau", [0.9, 0.95])
def test_zn_ultimate_pid_unstable_for_dominant_dead_time(tau):
    # Known failure, not a bug: Ziegler-Nichols ultimate-gain PID with the derivative filter n = 10
    # destabilizes its own FOPDT model for L/(L+T) above about 0.85 (Ms 6.7 at 0.8): the PID's
    # high-frequency gain K_u (1 + n)/1.7 exceeds 1/|G| where the plant hardly rolls off.
    model = FOPDTModel(1.0, 1.0 - tau, tau)
    assert not plant_margins(model.plant(), RULES["zn-ultimate-pid"].design(model)).stable


# --------------------------------------------------------------------------- boundary
def test_no_learning_package_imports():
    """gymnasium comes with `envs/__init__.py` (the registration); torch and SB3 never."""
    code = (
        "import sys, baselines.rules.pid, baselines.rules.pid_registry; "
        "bad = [m for m in ('torch', 'stable_baselines3') if m in sys.modules]; "
        "assert not bad, bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
