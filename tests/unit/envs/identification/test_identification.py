"""Identification formulas (the models and formulas of envs.identification) against exact and analytic references.

References: Gorez-Klan eq. 2-4 .. 2-10, the table of section 4 (P1, P2) and appendices A and B;
Ingimundarson eq. 10-12, 20-22, 45-46; Marlin section 6.3 (eq. 6.2-6.6).
"""

import math

import numpy as np
import pytest
import scipy.optimize

from envs.systems.controllers import PID
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel, model_from_dict
from envs.identification.moments import (
    apparent_time_constant,
    closed_loop_moments,
    fopdt_from_moments,
    normalized_moments,
    residence_time_from_area,
    sopdt_from_moments,
    theta_from_tau,
)
from envs.identification.open_loop_areas import (
    MIN_TIME_CONSTANT_FRACTION,
    fopdt_from_area,
    mismatch_time,
    pulse_mismatch_area,
    ramp_time_constant,
    step_time_constant,
)
from envs.identification.reaction_curve import reaction_curve_tangent, reaction_curve_two_point
from envs.identification.sampled_signals import integrate
from envs.simulation.loops import closed_loop_response
from envs.systems.plants import Plant
from envs.simulation.open_loop import open_loop_response


def exact_moment_fopdt(plant: Plant) -> tuple[float, float]:
    """``(T_ar, T_a)`` from the plant's exact Taylor coefficients (Gorez-Klan eq. 2-5, 2-6)."""
    p1, p2 = plant.taylor_coefficients()
    return -p1, math.sqrt(max(2 * p2 - p1 * p1, 0.0))


# --------------------------------------------------------------------------- theta (eq. 2-9, 2-10)
@pytest.mark.parametrize("tau", [0.0, 1e-6, 0.05, 0.2, 0.33, 0.5, 0.68, 0.9, 0.999, 1.0])
def test_theta_solves_eq_2_9_to_machine_precision(tau):
    theta = theta_from_tau(tau)
    assert (1 - theta) * math.sqrt(1 + theta**2) == pytest.approx(1 - tau, abs=4e-16)
    if 0 < tau < 1:  # an independent root of eq. 2-9
        root = scipy.optimize.brentq(lambda th: (1 - th) * math.sqrt(1 + th * th) - (1 - tau), 0.0, 1.0, xtol=1e-15)
        assert theta == pytest.approx(root, abs=1e-14)
    assert tau <= theta <= 1.0


@pytest.mark.parametrize("tau, theta", [(1 - 0.6716, 0.37), (1 - math.sqrt(0.1), 0.75)], ids=["P1", "P2"])
def test_theta_matches_gorez_klan_table(tau, theta):
    """The table's theta comes from the unrounded tau (P2: tau = 0.684, not the printed 0.68,
    which would give 0.743)."""
    assert round(theta_from_tau(tau), 2) == theta


@pytest.mark.parametrize("tau", [-0.1, 1.1, float("nan"), "0.3", True])
def test_theta_refuses_invalid_tau(tau):
    with pytest.raises(ValueError, match="tau"):
        theta_from_tau(tau)


# --------------------------------------------------------------------------- models from moments
@pytest.mark.parametrize(
    "time_constants, row",
    [
        # Gorez-Klan eq. 4-15 (alpha = 0.4) and 4-16 (n = 10), T_ar = 1; table of section 4:
        # T_a, D_a, tau, theta, T_1, T_2, D_2.
        ([0.4**k / (1 + 0.4 + 0.16 + 0.064) for k in range(4)], (0.67, 0.33, 0.33, 0.37, 0.63, 0.23, 0.14)),
        ([0.1] * 10, (0.32, 0.68, 0.68, 0.75, 0.25, 0.19, 0.56)),
    ],
    ids=["P1", "P2"],
)
def test_gorez_klan_table(time_constants, row):
    plant = Plant.from_time_constants(1.0, time_constants)
    residence_time, t_a = exact_moment_fopdt(plant)
    assert residence_time == pytest.approx(1.0)
    fopdt = fopdt_from_moments(plant.gain, residence_time, t_a)
    sopdt = sopdt_from_moments(plant.gain, residence_time, fopdt.normalized_dead_time)
    computed = (
        fopdt.time_constant,
        fopdt.dead_time,
        fopdt.normalized_dead_time,
        theta_from_tau(fopdt.normalized_dead_time),
        *sopdt.time_constants,
        sopdt.dead_time,
    )
    # The table prints two decimals; P2's T_2 = 0.1875 prints as 0.19 (rounded half up).
    assert np.allclose(computed, row, atol=0.0051)


@pytest.mark.parametrize("tau", [0.0, 0.1, 0.4, 0.8, 1.0])
def test_sopdt_from_moments_keeps_both_moments(tau):
    """Eq. 2-8 with eq. 2-9 keeps T_ar (eq. 2-5) and the second moment (eq. 2-6) of the FOPDT."""
    sopdt = sopdt_from_moments(2.0, 3.0, tau)
    t1, t2 = sopdt.time_constants
    assert sopdt.residence_time == pytest.approx(3.0)
    assert t1**2 + t2**2 == pytest.approx((3.0 * (1 - tau)) ** 2, abs=1e-12)
    assert sopdt.gain == 2.0


def test_sopdt_from_moments_refuses_bad_arguments():
    with pytest.raises(ValueError, match="gain must be non-zero"):
        sopdt_from_moments(0.0, 1.0, 0.5)
    with pytest.raises(ValueError, match="residence_time must be > 0"):
        sopdt_from_moments(1.0, -1.0, 0.5)


def test_apparent_time_constant_and_clipping():
    assert apparent_time_constant(3.0, (9.0 + 4.0) / 2) == pytest.approx(2.0)
    # (1 - 2s)/(s+1)^3: T_a^2 = 3 - 4 < 0 (appendix A) -> clipped to 0, tau = 1.
    plant = Plant.from_time_constants(1.0, [1, 1, 1], zero_time_constants=[-2.0])
    p1, p2 = plant.taylor_coefficients()
    assert 2 * p2 - p1**2 == pytest.approx(-1.0)
    assert apparent_time_constant(-p1, p2) == 0.0
    assert apparent_time_constant(1.0, 5.0) == 1.0  # T_a > T_ar clipped to T_ar
    fopdt = fopdt_from_moments(1.0, 2.0, 5.0)
    assert (fopdt.time_constant, fopdt.dead_time) == (2.0, 0.0)


# --------------------------------------------------------------------------- sampled moments
def fopdt_step(t, gain, time_constant, dead_time):
    return np.where(t > dead_time, gain * (1 - np.exp(-(t - dead_time) / time_constant)), 0.0)


def test_normalized_moments_of_an_analytic_step_response():
    t = np.linspace(0, 80, 80001)
    y = fopdt_step(t, 2.0, 3.0, 1.5)
    first, second = normalized_moments(t, y, 0.0, 2.0)
    assert first == pytest.approx(4.5, rel=1e-6)  # T_ar = T + L
    assert second == pytest.approx((4.5**2 + 3.0**2) / 2, rel=1e-6)  # eq. 2-6


def test_residence_time_from_area_open_loop_step():
    """Eq. 10 with a step input: the area between the normalized signals is T_ar."""
    t = np.linspace(0, 60, 60001)
    y = fopdt_step(t, -0.5, 2.0, 3.0)
    assert residence_time_from_area(t, np.ones_like(t), y, initial=(0.0, 0.0)) == pytest.approx(5.0, rel=1e-6)


def test_residence_time_from_area_refuses_flat_signals():
    t = np.linspace(0, 1, 11)
    with pytest.raises(ValueError, match="control must change"):
        residence_time_from_area(t, np.zeros(11), t)
    with pytest.raises(ValueError, match="output must have one value per time point"):
        residence_time_from_area(t, t, t[:5])


def pi_loop(plant: Plant, controller: PID, duration: float, dt: float):
    steps = int(duration / dt)
    response = closed_loop_response(plant, controller, steps, dt, setpoint=1.0)
    return response.timepts, response.control, response.output


def taylor_of_pi_loop(plant: Plant, controller: PID) -> tuple[float, float, float, float]:
    """Exact ``g1, g2, q1, q2`` of ``G = PC/(1+PC)`` and ``Q = G/(P/K)`` for a PI.

    With ``a = T_i/(K K_p)``: ``1/(PC) = a s - a (T_i + p_1) s^2 + O(s^3)``, so
    ``G = 1 - a s + (a (T_i + p_1) + a^2) s^2``; ``Q = G (1 - p_1 s + (p_1^2 - p_2) s^2)``.
    """
    p1, p2 = plant.taylor_coefficients()
    a = controller.ti / (plant.gain * controller.kp)
    g1, g2 = -a, a * (controller.ti + p1) + a * a
    return g1, g2, g1 - p1, g2 - g1 * p1 + p1 * p1 - p2


@pytest.mark.parametrize(
    "plant",
    [
        Plant.from_time_constants(1.0, [10.0, 2.0], 5.0),
        Plant.from_time_constants(-2.0, [1.0, 1.0, 1.0], 0.5),
        Plant.from_time_constants(0.5, [3.0, 1.0], 1.0, zero_time_constants=[-0.5]),
    ],
    ids=["ingimundarson-P1", "lag3-negative-gain", "nmp"],
)
def test_appendix_b_signs_against_exact_taylor_coefficients(plant):
    """Appendix B: the sampled integrals give -g1 (not g1 as printed), g2, -q1, q2."""
    residence_time, t_a = exact_moment_fopdt(plant)
    controller = PID(kp=0.5 / plant.gain, ti=residence_time)
    t, u, y = pi_loop(plant, controller, 60 * residence_time, residence_time / 400)
    moments = closed_loop_moments(t, u, y, 1.0 / plant.gain, 1.0)
    g1, g2, q1, q2 = taylor_of_pi_loop(plant, controller)
    scale = residence_time
    assert moments.g1 == pytest.approx(g1, abs=1e-6 * scale)
    assert moments.q1 == pytest.approx(q1, abs=1e-6 * scale)
    assert moments.g2 == pytest.approx(g2, abs=1e-5 * scale**2)
    assert moments.q2 == pytest.approx(q2, abs=1e-5 * scale**2)
    assert moments.residence_time == pytest.approx(residence_time, rel=1e-6)
    assert moments.apparent_time_constant == pytest.approx(t_a, abs=1e-3 * scale)
    # K = T_i/(-g1 K_p) holds with the Taylor coefficient g1 (negative) ...
    assert controller.ti / (-moments.g1 * controller.kp) == pytest.approx(plant.gain, rel=1e-6)
    # ... and the printed definition g1 = +int [1 - y/y(inf)] dt would give T_ar = q1 - g1 < 0.
    printed_g1, printed_q1 = -moments.g1, -moments.q1
    assert printed_q1 - printed_g1 == pytest.approx(-residence_time, rel=1e-6)
    # Eq. 10 (the area between u and y) is the same number as appendix B's q1 - g1.
    area = residence_time_from_area(t, u, y, initial=(0.0, 0.0), final=(1.0 / plant.gain, 1.0))
    assert area == pytest.approx(moments.residence_time, rel=1e-12)


def test_integrate_partial_interval_is_exact_for_linear_signals():
    t = np.linspace(0.0, 1.0, 11)
    assert integrate(t, 3 * t + 1, end=0.55) == pytest.approx(1.5 * 0.55**2 + 0.55, rel=1e-12)
    assert integrate(t, t, end=5.0) == pytest.approx(0.5)
    assert integrate(t, t, end=-1.0) == 0.0


# --------------------------------------------------------------------------- eq. 11, 12
@pytest.mark.parametrize("gain, time_constant, dead_time, height", [(1.0, 10.0, 5.0, 1.0), (-2.0, 0.3, 2.0, 0.5), (4.0, 3.0, 0.0, -2.0)])
def test_eq_11_and_12_recover_an_exact_fopdt(gain, time_constant, dead_time, height):
    residence_time = time_constant + dead_time
    t = np.linspace(0.0, residence_time, 200001)
    step = height * fopdt_step(t, gain, time_constant, dead_time)
    assert step_time_constant(np.trapezoid(step, t), height, gain) == pytest.approx(time_constant, rel=1e-8)
    s = np.maximum(t - dead_time, 0.0)
    ramp = height * gain * (s - time_constant * (1 - np.exp(-s / time_constant)))
    assert ramp_time_constant(np.trapezoid(ramp, t), height, gain) == pytest.approx(time_constant, rel=1e-8)


def test_fopdt_from_area_clips_to_keep_a_dead_time_and_a_lag():
    model = fopdt_from_area(1.0, 10.0, 12.0)
    assert (model.time_constant, model.dead_time) == (10.0, 0.0)
    model = fopdt_from_area(1.0, 10.0, -3.0)
    assert model.time_constant == pytest.approx(MIN_TIME_CONSTANT_FRACTION * 10.0)
    assert model.dead_time == pytest.approx(10.0 * (1 - MIN_TIME_CONSTANT_FRACTION))
    assert ramp_time_constant(-1.0, 1.0, 1.0) == 0.0
    with pytest.raises(ValueError, match="height must be non-zero"):
        step_time_constant(1.0, 0.0, 1.0)


# --------------------------------------------------------------------------- eq. 22, 46
def test_mismatch_time_of_a_dead_time_error_is_the_error():
    """Shifted monotone step responses enclose K |dL| (Ingimundarson section 4.2)."""
    t = np.linspace(0.0, 100.0, 100001)
    plant_response = fopdt_step(t, 2.0, 4.0, 3.0)
    assert mismatch_time(t, plant_response, FOPDTModel(2.0, 4.0, 3.0)) == pytest.approx(0.0, abs=1e-12)
    assert mismatch_time(t, plant_response, FOPDTModel(2.0, 4.0, 3.7)) == pytest.approx(0.7, rel=1e-5)
    assert mismatch_time(t, -plant_response, FOPDTModel(-2.0, 4.0, 2.5)) == pytest.approx(0.5, rel=1e-5)


def test_pulse_mismatch_area_of_a_dead_time_error():
    """For K e^{-Ls}/s and a model with L + d the pulse responses enclose K h tau d: A = K d."""
    t = np.linspace(0.0, 60.0, 60001)
    height, duration, gain = 2.0, 3.0, 0.5
    true_model = IntegratingModel(gain, 4.0)
    y = height * (true_model.step_response(t) - true_model.step_response(t - duration))
    assert pulse_mismatch_area(t, y, true_model, height, duration) == pytest.approx(0.0, abs=1e-12)
    area = pulse_mismatch_area(t, y, IntegratingModel(gain, 5.5), height, duration)
    assert area == pytest.approx(gain * 1.5, rel=1e-6)


# --------------------------------------------------------------------------- Marlin 6.3
def test_reaction_curve_two_point_is_exact_for_a_fopdt():
    t = np.linspace(0.0, 40.0, 40001)
    y = 3.0 * fopdt_step(t, 1.5, 4.0, 2.0)
    model = reaction_curve_two_point(t, y, 3.0, 4.5)
    assert (model.gain, model.time_constant, model.dead_time) == pytest.approx((1.5, 4.0, 2.0), rel=1e-6)


def test_reaction_curve_tangent_on_a_fopdt():
    """Method I: theta exact when L is on the grid, tau within dt/(2 T) (finite difference)."""
    dt, time_constant = 0.01, 4.0
    t = np.arange(0.0, 40.0, dt)
    y = -fopdt_step(t, 1.5, time_constant, 2.0)
    model = reaction_curve_tangent(t, y, -1.0, -1.5)
    assert model.gain == 1.5
    assert model.dead_time == pytest.approx(2.0, abs=1e-9)
    assert model.time_constant == pytest.approx(time_constant, rel=dt / time_constant)


def test_reaction_curve_tangent_on_a_second_order_plant():
    """1/((10s+1)(2s+1)): steepest slope at t* = ln(5)/0.4, tau = 1/y'(t*) (Marlin eq. 6.4)."""
    t = np.linspace(0.0, 100.0, 100001)
    model = SOPDTModel(1.0, (10.0, 2.0), 0.0)
    y = model.step_response(t)
    t_star = math.log(5) / 0.4
    slope = (math.exp(-t_star / 10) - math.exp(-t_star / 2)) / 8
    level = float(model.step_response(np.array([t_star]))[0])
    fitted = reaction_curve_tangent(t, y, 1.0, 1.0)
    assert fitted.time_constant == pytest.approx(1 / slope, rel=1e-5)
    assert fitted.dead_time == pytest.approx(t_star - level / slope, rel=1e-4)


def test_reaction_curves_refuse_curves_that_never_rise():
    t = np.linspace(0, 1, 11)
    with pytest.raises(ValueError, match="never reaches"):
        reaction_curve_two_point(t, 0.1 * t, 1.0, 1.0)
    with pytest.raises(ValueError, match="window"):
        reaction_curve_tangent(t, t, 1.0, 1.0, window=1)


# --------------------------------------------------------------------------- models
MODELS = [
    FOPDTModel(2.0, 3.0, 1.0),
    FOPDTModel(-1.0, 0.0, 2.0),
    SOPDTModel(1.5, (4.0, 1.0), 0.5),
    SOPDTModel(1.0, (2.0, 2.0), 1.0),
    SOPDTModel(-3.0, (0.0, 2.0), 1.0),
    IntegratingModel(0.5, 2.0),
    IntegratingModel(-0.2, 1.0, 3.0),
]


@pytest.mark.parametrize("model", MODELS, ids=repr)
def test_model_json_round_trip(model):
    assert model_from_dict(model.to_dict()) == model


@pytest.mark.parametrize("model", MODELS, ids=repr)
def test_model_step_response_is_the_plants(model):
    """The analytic step response against the exact simulation of ``model.plant()``."""
    plant = model.plant()
    dt = 0.01
    t = np.arange(3000) * dt
    simulated = open_loop_response(plant.state_space(), plant.dead_time, np.ones(t.size), dt)
    assert np.allclose(model.step_response(t), simulated, atol=1e-9 * max(1.0, np.max(np.abs(simulated))))
    assert plant.gain == pytest.approx(model.gain)


def test_model_properties():
    fopdt = FOPDTModel(1.0, 3.0, 1.0)
    assert (fopdt.residence_time, fopdt.normalized_dead_time) == (4.0, 0.25)
    assert SOPDTModel(1.0, (3.0, 1.0), 1.0).residence_time == 5.0
    assert IntegratingModel(1.0, 2.0, 1.0).residence_time == 3.0
    assert IntegratingModel(1.0, 2.0).plant().residence_time == pytest.approx(2.0)
    assert FOPDTModel(1.0, 3.0, 1.0).to_dict() == {"type": "fopdt", "gain": 1.0, "time_constant": 3.0, "dead_time": 1.0}
    assert SOPDTModel(1.0, (3.0, 1.0), 1.0).to_dict()["time_constants"] == [3.0, 1.0]
    assert IntegratingModel(1.0, 2.0).to_dict() == {"type": "integrating", "gain": 1.0, "dead_time": 2.0, "time_constant": None}


@pytest.mark.parametrize(
    "data, message",
    [
        ([1, 2], "model must be a JSON object"),
        ({"type": "pid"}, "model.type must be one of"),
        ({"type": "fopdt", "gain": 1.0, "time_constant": 1.0}, "missing key 'dead_time'"),
        ({"type": "fopdt", "gain": 1.0, "time_constant": 1.0, "dead_time": 1.0, "tau": 0.5}, "unknown key 'tau'"),
        ({"type": "fopdt", "gain": 0.0, "time_constant": 1.0, "dead_time": 1.0}, "model.gain must be non-zero, got 0.0"),
        ({"type": "fopdt", "gain": 1.0, "time_constant": -1.0, "dead_time": 1.0}, "model.time_constant must be >= 0"),
        ({"type": "fopdt", "gain": 1.0, "time_constant": 0.0, "dead_time": 0.0}, "time_constant \\+ dead_time must be > 0"),
        ({"type": "fopdt", "gain": "1", "time_constant": 1.0, "dead_time": 1.0}, "model.gain must be a number"),
        ({"type": "fopdt", "gain": True, "time_constant": 1.0, "dead_time": 1.0}, "model.gain must be a number"),
        ({"type": "sopdt", "gain": 1.0, "time_constants": 2.0, "dead_time": 1.0}, "model.time_constants must be a list"),
        ({"type": "sopdt", "gain": 1.0, "time_constants": [1.0], "dead_time": 1.0}, "time_constants must be a pair"),
        ({"type": "sopdt", "gain": 1.0, "time_constants": [1.0, -2.0], "dead_time": 1.0}, "model.time_constants\\[1\\] must be >= 0"),
        ({"type": "integrating", "gain": 1.0, "dead_time": float("inf")}, "model.dead_time must be finite"),
        ({"type": "integrating", "gain": 1.0, "dead_time": 1.0, "time_constant": -1}, "model.time_constant must be >= 0"),
    ],
)
def test_model_from_dict_names_the_field(data, message):
    with pytest.raises(ValueError, match=message):
        model_from_dict(data)
