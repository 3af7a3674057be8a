"""Controllers (envs.systems.controllers) and closed loops (envs.simulation.loops) in the frequency domain.

Cross-checks:

* each controller's ``reference_response``/``feedback_response`` against its block diagram
  (Marlin ch. 8 for the PID forms; Ingimundarson Fig. 4 and eq. 13-15 for the FPPI, Fig. 10 and
  eq. 35-38, 51 for the MSP) solved numerically as linear equations in the signals at each
  frequency;
* each controller's state-space ``block()`` against those transfer functions;
* the closed loop ``closed_loop(plant, controller)`` (inputs r, l, n; outputs y, u, e) against
  the closed-form ``S``, ``P S``, ``T`` built from ``loop_response`` and ``reference_response``;
* the papers' closed forms: the nominal set-point response ``e^{-L_n s}/(T_r s + 1)`` of the FPPI
  (eq. 15) and the MSP (eq. 37), the MSP loop with a dead-time error (eq. 47), the Gorez-Klan
  model loop ``e^{-D_2 s}/(mu D_2 s)`` (eq. 3-12);
* ``controller_from_dict`` refuses bad input with a ValueError naming the field.

All frequency-domain comparisons are exact evaluations of the same rational/exponential functions
by different routes, so the tolerance is ``1e-10`` relative.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from envs.systems.controllers import FPPI, MSP, PID, SeriesPID, controller_from_dict
from envs.simulation.loops import closed_loop, loop_response
from envs.systems.plants import Plant

OMEGA = np.logspace(-3, 2, 300)


def _close(actual, expected, rtol=1e-10):
    """``|actual - expected| <= rtol max(1, |expected|)`` element-wise."""
    actual, expected = np.asarray(actual), np.asarray(expected)
    bound = rtol * np.maximum(1.0, np.abs(expected))
    worst = np.max(np.abs(actual - expected) / bound)
    assert worst <= 1.0, f"deviation {worst * rtol:.3g} (relative) exceeds {rtol:g}"


# ----------------------------------------------------------------------------- block diagrams
def diagram_responses(controller, omega):
    """``(C_ff, C_fb)`` with ``u = C_ff r - C_fb y``, from the controller's block diagram."""
    s = 1j * np.asarray(omega, dtype=float)
    if isinstance(controller, PID):
        integral = 0 if controller.ti is None else 1 / (controller.ti * s)
        derivative = controller.td * s / (1 + controller.td * s / controller.n) if controller.td > 0 else 0
        c = controller.kp * (1 + integral + derivative)
        return c, c
    if isinstance(controller, SeriesPID):
        integral = 0 if controller.ti is None else 1 / (controller.ti * s)
        lead = (1 + controller.td * s) / (1 + controller.td * s / controller.n) if controller.td > 0 else 1
        c = controller.kp * (1 + integral) * lead
        return c, c
    if isinstance(controller, FPPI):
        # u = C eps,  eps = r - G_n u - F (y - G_n e^{-L_n s} u)   (Fig. 4), unknowns [u, eps]
        gain, tn, ln = controller.gain, controller.time_constant, controller.dead_time
        c = tn / (gain * controller.tr) * (1 + 1 / (tn * s))  # eq. 14-15: T_i = T_n, K = T_n/(K_n T_r)
        g = gain / (tn * s + 1)
        f = 1 / (controller.tf * s + 1)
        delay = np.exp(-ln * s)
        A = np.zeros((s.size, 2, 2), dtype=complex)
        A[:, 0, 0], A[:, 0, 1] = 1, -c
        A[:, 1, 0], A[:, 1, 1] = g * (1 - f * delay), 1
        rhs = np.zeros((s.size, 2, 2), dtype=complex)  # columns: r = 1, y = 1
        rhs[:, 1, 0], rhs[:, 1, 1] = 1, -f
        u = np.linalg.solve(A, rhs)[:, 0, :]
        return u[:, 0], -u[:, 1]
    if isinstance(controller, MSP):
        # e_d = y - G_n e^{-L_n s} u_r,  u_r = K_r (r - G_n u_r - e_d),  u = u_r - F e_d   (Fig. 10)
        gain, ln = controller.gain, controller.dead_time
        kr = 1 / (gain * controller.tr)  # eq. 38
        if controller.extension:  # eq. 51
            td = 0.4 * ln
            f = 0.6 / (ln * gain) * (td * s + 1) / (td * s / 10 + 1)
        else:  # eq. 36
            f = 1 / (2 * ln * gain) * np.ones_like(s)
        g = gain / s
        delay = np.exp(-ln * s)
        A = np.zeros((s.size, 3, 3), dtype=complex)  # unknowns [u_r, e_d, u]
        A[:, 0, 0], A[:, 0, 1] = g * delay, 1
        A[:, 1, 0], A[:, 1, 1] = 1 + kr * g, kr
        A[:, 2, 0], A[:, 2, 1], A[:, 2, 2] = -1, f, 1
        rhs = np.zeros((s.size, 3, 2), dtype=complex)
        rhs[:, 1, 0] = kr
        rhs[:, 0, 1] = 1
        u = np.linalg.solve(A, rhs)[:, 2, :]
        return u[:, 0], -u[:, 1]
    raise TypeError(controller)


CONTROLLERS = {
    "pid": PID(kp=1.3, ti=2.0, td=0.4, n=8.0),
    "pid-pi": PID(kp=0.7, ti=1.5),
    "pid-pd": PID(kp=2.0, ti=None, td=0.3, n=5.0),
    "pid-negative-gain": PID(kp=-0.9, ti=1.1, td=0.2, n=10.0),
    "series-pid": SeriesPID(kp=1.1, ti=1.7, td=0.6, n=10.0),
    "series-pid-gorez-klan": SeriesPID.gorez_klan(2.0, (3.0, 1.0), 1.5, mu=2.0, n=10.0),
    "fppi": FPPI(gain=1.5, time_constant=2.0, dead_time=1.2, tr=1.0, tf=1.0),
    "fppi-unfiltered": FPPI(gain=1.5, time_constant=2.0, dead_time=1.2, tr=0.8, tf=0.0),
    "fppi-no-dead-time": FPPI(gain=0.7, time_constant=1.0, dead_time=0.0, tr=0.5, tf=0.3),
    "msp": MSP(gain=0.8, dead_time=2.0, tr=1.5),
    "msp-extension": MSP(gain=0.8, dead_time=2.0, tr=1.5, extension=True),
}


@pytest.mark.parametrize("name", CONTROLLERS)
def test_transfer_functions_match_the_block_diagram(name):
    controller = CONTROLLERS[name]
    c_ff, c_fb = diagram_responses(controller, OMEGA)
    _close(controller.reference_response(OMEGA), c_ff)
    _close(controller.feedback_response(OMEGA), c_fb)


@pytest.mark.parametrize("name", CONTROLLERS)
def test_state_space_block_matches_the_transfer_functions(name):
    """``block()`` has inputs ``[r, y_measured]`` and output ``u = C_ff r - C_fb y``."""
    controller = CONTROLLERS[name]
    response = controller.block().frequency_response(OMEGA)
    assert response.shape == (OMEGA.size, 1, 2)
    _close(response[:, 0, 0], controller.reference_response(OMEGA))
    _close(response[:, 0, 1], -controller.feedback_response(OMEGA))


# ----------------------------------------------------------------------------- closed loops
LOOPS = {
    "pid-fopdt": (Plant.from_time_constants(1.0, [1.0], 0.5), PID(1.0, 1.0, 0.1, 10.0)),
    "pid-biproper-no-delay": (Plant([0.5, 1.0], [2.0, 1.0], 0.0), PID(1.5, 1.0, 0.2, 10.0)),  # algebraic loop
    "pi-integrating": (Plant.from_time_constants(0.5, [1.0], 1.0, integrating=True), PID(0.3, 8.0)),
    "series-pid-lag-chain": (Plant.from_time_constants(2.0, [1.0, 0.5, 0.25, 0.125], 1.0), SeriesPID.gorez_klan(2.0, (1.0, 0.5), 1.4, 2.0, 10.0)),
    "series-pid-no-delay": (Plant.from_time_constants(1.0, [1.0] * 4), SeriesPID(0.6, 2.0, 1.0, 10.0)),
    "fppi-filtered": (Plant.from_time_constants(1.0, [1.0, 0.5], 0.4), FPPI(1.0, 1.2, 0.7, 1.0, 1.0)),
    "fppi-unfiltered": (Plant.from_time_constants(1.0, [1.0, 0.5], 0.4), FPPI(1.0, 1.2, 0.7, 1.0, 0.0)),
    "fppi-model-without-dead-time": (Plant.from_time_constants(1.0, [1.0, 0.5], 0.4), FPPI(1.0, 1.2, 0.0, 1.0, 0.5)),
    "fppi-plant-without-dead-time": (Plant.from_time_constants(1.0, [1.0, 0.5]), FPPI(1.0, 1.2, 0.3, 1.0, 0.5)),
    "msp-integrating": (Plant.from_time_constants(1.0, [0.5], 1.0, integrating=True), MSP(1.0, 1.5, 1.5)),
    "msp-extension": (Plant.from_time_constants(1.0, [0.5], 1.0, integrating=True), MSP(1.0, 1.5, 1.5, extension=True)),
}


@pytest.mark.parametrize("name", LOOPS)
def test_closed_loop_frequency_response_equals_sensitivity_functions(name):
    """Inputs ``[r, l, n]``, outputs ``[y, u, e]`` of ``y = P (u + l)``, ``u = C_ff r - C_fb (y + n)``:

    ``y = P C_ff S r + P S l - T n``, ``u = C_ff S r - T l - C_fb S n``, ``e = r - y``,
    with ``L = P C_fb`` from ``loop_response``, ``S = 1/(1 + L)``, ``T = L S``."""
    plant, controller = LOOPS[name]
    omega = OMEGA / plant.step_time_scale()
    s = 1j * omega
    p = np.polyval(plant.num, s) / np.polyval(plant.den, s) * np.exp(-plant.dead_time * s)
    loop = loop_response(plant, controller, omega)
    _close(loop, p * diagram_responses(controller, omega)[1])
    c_ff = controller.reference_response(omega)
    c_fb = loop / p
    sens = 1 / (1 + loop)
    comp = loop * sens
    expected = np.empty((omega.size, 3, 3), dtype=complex)
    expected[:, 0] = np.stack([p * c_ff * sens, p * sens, -comp], axis=1)
    expected[:, 1] = np.stack([c_ff * sens, -comp, -c_fb * sens], axis=1)
    expected[:, 2] = np.stack([1 - p * c_ff * sens, -p * sens, comp], axis=1)
    _close(closed_loop(plant, controller).frequency_response(omega), expected)


@pytest.mark.parametrize("tf", [0.0, 0.5, 2.0])
def test_fppi_nominal_setpoint_response_is_first_order_plus_dead_time(tf):
    """Ingimundarson eq. 15: with ``P = P_n`` the set-point response is ``e^{-L_n s}/(T_r s + 1)``,
    whatever the filter."""
    gain, tn, ln, tr = 1.7, 3.0, 1.4, 0.9
    plant = Plant.from_time_constants(gain, [tn], ln)
    response = closed_loop(plant, FPPI(gain, tn, ln, tr, tf)).frequency_response(OMEGA)
    s = 1j * OMEGA
    _close(response[:, 0, 0], np.exp(-ln * s) / (tr * s + 1))


@pytest.mark.parametrize("extension", [False, True])
def test_msp_nominal_setpoint_response_is_first_order_plus_dead_time(extension):
    """Ingimundarson eq. 37: with ``P = K_n e^{-L_n s}/s`` the set-point response is
    ``e^{-L_n s}/(T_r s + 1)``."""
    gain, ln, tr = 0.6, 2.5, 1.8
    plant = Plant([gain], [1.0, 0.0], ln)
    response = closed_loop(plant, MSP(gain, ln, tr, extension)).frequency_response(OMEGA)
    s = 1j * OMEGA
    _close(response[:, 0, 0], np.exp(-ln * s) / (tr * s + 1))


@pytest.mark.parametrize("dead_time_error", [-0.5, 0.0, 0.3])
def test_msp_loop_with_a_dead_time_error_is_eq_47(dead_time_error):
    """Ingimundarson eq. 47: on ``P = K_n e^{-L s}/s`` the MSP loop is
    ``L(s) = e^{-L s}((2 L_n + T_r) s + 1) / (2 s L_n (T_r s + 1 - e^{-L_n s}))``, whatever ``K_n``."""
    gain, ln, tr = 2.3, 1.5, 0.7
    true_delay = ln * (1 + dead_time_error)
    loop = loop_response(Plant([gain], [1.0, 0.0], true_delay), MSP(gain, ln, tr), OMEGA)
    s = 1j * OMEGA
    expected = np.exp(-true_delay * s) * ((2 * ln + tr) * s + 1) / (2 * s * ln * (tr * s + 1 - np.exp(-ln * s)))
    _close(loop, expected)


def test_gorez_klan_model_loop_is_a_delayed_integrator():
    """Gorez-Klan eq. 3-11/3-12: on the SOPDT model the series PID gives ``e^{-D_2 s}/(mu D_2 s)``
    up to the derivative filter (here made negligible with a very large ``n``)."""
    gain, t1, t2, d2, mu = 1.8, 4.0, 1.5, 2.0, 2.5
    plant = Plant.from_time_constants(gain, [t1, t2], d2)
    controller = SeriesPID.gorez_klan(gain, (t1, t2), d2, mu=mu, n=1e9)
    assert (controller.ti, controller.td) == (t1, t2)
    s = 1j * OMEGA
    _close(loop_response(plant, controller, OMEGA), np.exp(-d2 * s) / (mu * d2 * s), rtol=1e-7)


# ----------------------------------------------------------------------------- controller_from_dict
GOOD_DICTS = [
    {"type": "pid", "kp": 1.0, "ti": 2.0, "td": 0.5, "n": 8},
    {"type": "pid", "kp": 1.0, "ti": None},
    {"type": "pid-series", "kp": 0.5, "ti": 3.0, "td": 1.0},
    {"type": "fppi", "model": {"gain": 2.0, "time_constant": 3.0, "dead_time": 1.0}, "tr": 1.5, "tf": 1.5},
    {"type": "fppi", "model": {"gain": -2.0, "time_constant": 3.0, "dead_time": 0.0}, "tr": 1.5},
    {"type": "msp", "model": {"gain": 0.1, "dead_time": 5.0}, "tr": 2.0, "extension": True},
]


@pytest.mark.parametrize("data", GOOD_DICTS, ids=lambda d: d["type"])
def test_controller_dict_round_trip(data):
    controller = controller_from_dict(data)
    assert controller_from_dict(controller.to_dict()) == controller


PID_OK = {"type": "pid", "kp": 1.0, "ti": 2.0}
FPPI_OK = {"type": "fppi", "model": {"gain": 2.0, "time_constant": 3.0, "dead_time": 1.0}, "tr": 1.5}
MSP_OK = {"type": "msp", "model": {"gain": 0.1, "dead_time": 5.0}, "tr": 2.0}


def _with(base, **changes):
    out = {**base, **changes}
    return {k: v for k, v in out.items() if v is not _DROP}


def _with_model(base, **changes):
    model = {k: v for k, v in {**base["model"], **changes}.items() if v is not _DROP}
    return {**base, "model": model}


_DROP = object()

# (controller JSON, regex that the message must match: it names the offending field)
BAD_DICTS = {
    "not-an-object": ([1, 2], r"controller must be"),
    "unknown-type": (_with(PID_OK, type="pi-lambda"), r"controller\.type"),
    "missing-type": (_with(PID_OK, type=_DROP), r"controller\.type"),
    "unknown-key": (_with(PID_OK, tau=3.0), r"unknown key 'tau'"),
    "missing-key": (_with(PID_OK, ti=_DROP), r"missing key 'ti'"),
    "nan-kp": (_with(PID_OK, kp=math.nan), r"\bkp\b.*finite"),
    "infinite-ti": (_with(PID_OK, ti=math.inf), r"\bti\b.*finite"),
    "negative-ti": (_with(PID_OK, ti=-1.0), r"\bti\b.*> 0"),
    "zero-ti": (_with(PID_OK, ti=0.0), r"\bti\b.*> 0"),
    "zero-kp": (_with(PID_OK, kp=0.0), r"\bkp\b.*non-zero"),
    "string-kp": (_with(PID_OK, kp="1"), r"\bkp\b.*number"),
    "bool-kp": (_with(PID_OK, kp=True), r"\bkp\b.*number"),
    "negative-td": (_with(PID_OK, td=-0.1), r"\btd\b"),
    "zero-n": (_with(PID_OK, td=0.5, n=0.0), r"\bn\b.*> 0"),
    "fppi-model-not-object": (_with(FPPI_OK, model=[2.0, 3.0, 1.0]), r"\bmodel\b"),
    "fppi-model-missing-key": (_with_model(FPPI_OK, time_constant=_DROP), r"model.*'time_constant'"),
    "fppi-model-unknown-key": (_with_model(FPPI_OK, tau=0.3), r"model.*'tau'"),
    "fppi-negative-dead-time": (_with_model(FPPI_OK, dead_time=-1.0), r"dead_time"),
    "fppi-nan-gain": (_with_model(FPPI_OK, gain=math.nan), r"gain.*finite"),
    "fppi-zero-tr": (_with(FPPI_OK, tr=0.0), r"\btr\b"),
    "fppi-negative-tf": (_with(FPPI_OK, tf=-1.0), r"\btf\b"),
    "msp-zero-dead-time": (_with_model(MSP_OK, dead_time=0.0), r"dead_time"),
    "msp-extension-not-bool": (_with(MSP_OK, extension="yes"), r"extension"),
    "msp-time-constant-key": (_with_model(MSP_OK, time_constant=1.0), r"model.*'time_constant'"),
}


@pytest.mark.parametrize("name", BAD_DICTS)
def test_controller_from_dict_refuses_bad_input(name):
    data, pattern = BAD_DICTS[name]
    with pytest.raises(ValueError, match=pattern):
        controller_from_dict(data)


@pytest.mark.parametrize("kind", [["pid"], {"pid": 1}, 1, None])
def test_controller_from_dict_refuses_a_type_that_is_not_a_name(kind):
    """Regression: a list or object ``type`` used to raise ``TypeError: unhashable type``."""
    with pytest.raises(ValueError, match=r"controller\.type"):
        controller_from_dict({"type": kind, "kp": 1.0, "ti": 1.0})
