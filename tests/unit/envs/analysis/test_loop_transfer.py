"""The loop transfer as a ratio of quasi-polynomials (envs.analysis.loop_transfer).

Cross-checks:

* the quasi-rational form of every controller type (the derivations in the module docstring:
  Ingimundarson eq. 13-16 for the FPPI, eq. 35-38 and 51 for the MSP) against
  :func:`envs.simulation.loops.loop_response`, which evaluates the controllers' own block-diagram formulas,
  in numpy (:meth:`QuasiRational.response`) and compiled
  (:func:`envs.analysis._robustness_kernels.transfer_at`, through ``_evaluate``);
* the compiled evaluation against the same quasi-polynomials evaluated with 40 significant digits
  (mpmath), down to ``omega T = 1e-9`` where ``loop_response`` has lost digits;
* the PID coefficients against the controllers' ``transfer_function``.

Tolerances: ``loop_response`` and the quasi-rational form evaluate the same functions by different
routes, with rounding errors of a few ``eps`` times the condition of the evaluation.  For FPPI and
MSP that condition is ``1/(omega T)`` at low frequencies (``(T_f s + 1) - e^{-L_n s}`` and
``T_r s + 1 - e^{-L_n s}`` are differences of nearly equal terms) and ``omega L`` at high
frequencies (the dead times' phase), so the bound below is ``1e-14 (1 + 1/(omega T) + omega L)``
(measured: at most ``1e-15 (1 + 1/(omega T) + omega L)`` on these loops).
"""

from __future__ import annotations

import numpy as np
import pytest

from envs.analysis._robustness_kernels import _evaluate as _compiled  # transfer_at on an array
from envs.systems.controllers import FPPI, MSP, PID, SeriesPID
from envs.analysis.loop_transfer import QuasiRational, _loop_terms, _pid, feedback_transfer, loop_packed, loop_transfer, packed
from envs.simulation.loops import loop_response
from envs.systems.plants import Plant

PLANTS = {
    "fopdt": Plant.from_time_constants(1.5, [2.0], 0.7),
    "lag-chain": Plant.from_time_constants(-0.8, [1.0, 0.5, 0.25, 0.125], 0.3),
    "nmp-zero": Plant(num=[-1.0, 1.0], den=[1.0, 3.0, 3.0, 1.0], dead_time=0.5),
    "no-delay": Plant.from_time_constants(2.0, [1.0, 0.2]),
    "integrating": Plant.from_time_constants(0.5, [0.4], 1.2, integrating=True),
    "pure-delay": Plant([1.0], [1.0], 1.0),
}
CONTROLLERS = {
    "pi": PID(0.8, 1.5),
    "p": PID(0.3, None),
    "pid": PID(1.2, 1.5, 0.3, 8.0),
    "pd": PID(1.2, None, 0.3, 8.0),
    "series-pid": SeriesPID(0.9, 1.3, 0.4, 10.0),
    "series-pi": SeriesPID(0.9, 1.3),
    "fppi": FPPI(1.4, 1.8, 0.6, 0.9, 0.9),
    "fppi-unfiltered": FPPI(1.4, 1.8, 0.6, 0.9, 0.0),
    "fppi-no-model-delay": FPPI(-0.7, 1.8, 0.0, 0.5, 0.5),
    "msp": MSP(0.6, 1.1, 2.0),
    "msp-extension": MSP(0.6, 1.1, 2.0, True),
}


def _bound(transfer: QuasiRational, omega: np.ndarray, time_scale: float) -> np.ndarray:
    """``1e-14 (1 + 1/(omega T) + omega L)``, ``L`` the largest dead time (module docstring)."""
    delays = [d for _, d in transfer.numerator + transfer.denominator]
    return 1e-14 * (1 + 1 / (omega * time_scale) + omega * max(delays))


@pytest.mark.parametrize("controller", CONTROLLERS)
@pytest.mark.parametrize("plant", PLANTS)
def test_quasi_rational_form_equals_loop_response(plant, controller):
    plant, controller = PLANTS[plant], CONTROLLERS[controller]
    time_scale = plant.step_time_scale()
    omega = np.logspace(-6, 3, 400) / time_scale
    expected = loop_response(plant, controller, omega)
    transfer = loop_transfer(plant, controller)
    bound = _bound(transfer, omega, time_scale)
    assert np.all(np.abs(transfer.response(omega) / expected - 1) <= bound)
    assert np.all(np.abs(_compiled(transfer.arrays, omega) / expected - 1) <= bound)


@pytest.mark.parametrize("controller", ["fppi", "fppi-unfiltered", "msp", "msp-extension", "series-pid"])
def test_compiled_evaluation_is_accurate_to_rounding_at_every_frequency(controller):
    """Against 40-digit arithmetic on the same coefficients, from ``omega T = 1e-9``: ``1e-14
    (1 + omega L)`` relative (measured 4e-14 at ``omega L = 3e3``); ``loop_response`` is 1e-9 off
    at ``omega T = 1e-9`` (the cancellation the compiled form avoids)."""
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 40
    plant = PLANTS["integrating"] if controller.startswith("msp") else PLANTS["lag-chain"]
    transfer = loop_transfer(plant, CONTROLLERS[controller])
    time_scale = plant.step_time_scale()
    omega = np.logspace(-9, 3, 60) / time_scale

    def side(terms, s):
        return sum(mpmath.polyval([mpmath.mpf(c) for c in p], s) * mpmath.exp(-s * mpmath.mpf(d)) for p, d in terms)

    exact = np.array([complex(side(transfer.numerator, 1j * w) / side(transfer.denominator, 1j * w)) for w in omega])
    largest_delay = max(d for _, d in transfer.numerator + transfer.denominator)
    error = np.abs(_compiled(transfer.arrays, omega) / exact - 1)
    assert np.all(error <= 1e-14 * (1 + omega * largest_delay))


@pytest.mark.parametrize("controller", ["pi", "p", "pid", "pd", "series-pid", "series-pi"])
def test_pid_coefficients_are_those_of_transfer_function(controller):
    controller = CONTROLLERS[controller]
    (numerator, _), = _pid(controller).numerator
    (denominator, _), = _pid(controller).denominator
    num, den = controller.transfer_function()
    np.testing.assert_allclose(numerator, num, rtol=1e-15, atol=0)
    np.testing.assert_allclose(denominator, den, rtol=1e-15, atol=0)


def test_fppi_integrator_is_exact_without_model_dead_time():
    """``L_n = 0``: both denominator terms have dead time 0; the polynomial of their summed
    coefficients, ``T_n s (T_f s + 1) + K K_n T_f s``, has an exact root at the origin, and
    ``Re(L s) -> P(0) K/(T_n + K K_n T_f)`` to rounding at ``omega = 1e-12`` (``Im(L s)`` is of order
    ``omega``)."""
    plant, controller = PLANTS["fopdt"], CONTROLLERS["fppi-no-model-delay"]
    rows, delays = feedback_transfer(controller).arrays[2:]
    assert list(delays) == [0.0, 0.0] and rows[:, -1].sum() == 0.0
    k, k_kn = controller.proportional_gain, controller.time_constant / controller.tr
    limit = plant.gain * k / (controller.time_constant + k_kn * controller.tf)
    scaled = _compiled(loop_transfer(plant, controller).arrays, np.array([1e-12]))[0] * 1e-12j
    assert abs(scaled.real / limit - 1) < 1e-14


def test_plant_dead_time_goes_to_every_numerator_term():
    plant, controller = PLANTS["fopdt"], CONTROLLERS["msp"]
    transfer = loop_transfer(plant, controller)
    assert [d for _, d in transfer.numerator] == [plant.dead_time]
    assert sorted(d for _, d in transfer.denominator) == [0.0, controller.dead_time]


def test_unknown_controller_is_refused():
    with pytest.raises(TypeError, match="PID, SeriesPID, FPPI or MSP"):
        feedback_transfer(object())


def test_gorez_klan_model_loop_by_hand():
    """``e^{-s}/(2 s)`` written directly: ``|L| = 1/(2 omega)``, ``arg L = -pi/2 - omega``."""
    transfer = QuasiRational((((1.0,), 1.0),), (((2.0, 0.0), 0.0),))
    omega = np.array([0.1, 0.5, 2.0])
    expected = np.exp(-1j * omega) / (2j * omega)
    np.testing.assert_allclose(transfer.response(omega), expected, rtol=1e-15)
    np.testing.assert_allclose(_compiled(transfer.arrays, omega), expected, rtol=1e-15)


def _random_controllers(rng: np.random.Generator, count: int) -> list:
    """Controllers of every kind and option (signs, missing integral or derivative, filters)."""
    made = []
    for i in range(count):
        u = rng.uniform
        kind = i % 6
        if kind == 0:
            made.append(PID(u(-3, 3), u(0.1, 5), u(0, 2) * (rng.random() < 0.7), u(2, 20)))
        elif kind == 1:
            made.append(SeriesPID(u(0.1, 3), u(0.1, 5), u(0, 2) * (rng.random() < 0.7), u(2, 20)))
        elif kind == 2:
            made.append(PID(u(0.1, 3), None, u(0, 2) * (rng.random() < 0.5), u(2, 20)))
        elif kind == 3:
            made.append(FPPI(u(-3, 3), u(0.1, 5), u(0, 3), u(0.1, 5), u(0, 2) * (rng.random() < 0.7)))
        elif kind == 4:
            made.append(MSP(u(-3, 3), u(0.1, 3), u(0.1, 5), bool(rng.random() < 0.5)))
        else:
            made.append(SeriesPID(u(0.1, 3), None, u(0, 2), u(2, 20)))
    return made


def test_compiled_loop_packed_equals_python_packing_bit_for_bit():
    """loop_packed's compiled method against its reference (packed(*_loop_terms(...)), the Python arithmetic)."""
    pairs = [(p, c) for p in PLANTS.values() for c in CONTROLLERS.values()]
    rng = np.random.default_rng(3)
    plants = list(PLANTS.values())
    pairs += [(plants[rng.integers(len(plants))], c) for c in _random_controllers(rng, 600)]
    for plant, controller in pairs:
        flat, shape = loop_packed(plant, controller)
        expected, expected_shape = loop_packed(plant, controller, method="reference")
        assert expected.tobytes() == packed(*_loop_terms(plant, controller))[0].tobytes()
        assert shape == expected_shape
        assert flat.dtype == expected.dtype and flat.tobytes() == expected.tobytes(), (plant, controller)


def test_loop_packed_refuses_unknown_controller():
    with pytest.raises(TypeError, match="PID, SeriesPID, FPPI or MSP"):
        loop_packed(PLANTS["fopdt"], object())
    with pytest.raises(ValueError, match="method must be"):
        loop_packed(PLANTS["fopdt"], CONTROLLERS["pid"], method="fast")
