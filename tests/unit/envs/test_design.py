"""The design maps of envs/design.py against the closed forms of the papers.

* Gorez-Klan eq. 3-12: on its own SOPDT model the PID gives the loop ``e^{-D2 s}/(mu D2 s)``, here
  times the derivative filter ``1/(T2 s/N + 1)``.
* Ingimundarson eq. 15 and 37: with a perfect model the FPPI and the MSP give the set-point response
  ``e^{-L_n s}/(T_r s + 1)``; the FPPI's filter is ``T_f = T_r`` (section 4.3).
"""

import numpy as np
import pytest

from envs.design import DERIVATIVE_FILTER, fppi_design, msp_design, pid_design
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.simulation.loops import loop_response

OMEGA = np.logspace(-2, 2, 50)


@pytest.mark.parametrize("mu", [1.3, 2.0, 5.0])
def test_pid_design_gives_the_gorez_klan_loop(mu):
    model = SOPDTModel(gain=-2.0, time_constants=(3.0, 0.8), dead_time=0.6)
    loop = loop_response(model.plant(), pid_design(model, mu), OMEGA)
    s = 1j * OMEGA
    expected = np.exp(-0.6 * s) / (mu * 0.6 * s * (0.8 * s / DERIVATIVE_FILTER + 1))
    assert np.max(np.abs(loop / expected - 1)) < 1e-12


def test_fppi_design_nominal_setpoint_response_is_first_order():
    model = FOPDTModel(gain=1.5, time_constant=4.0, dead_time=2.0)
    controller = fppi_design(model, 1.2)
    assert controller.tf == controller.tr == 1.2
    plant = model.plant()
    s = 1j * OMEGA
    loop = loop_response(plant, controller, OMEGA)
    setpoint = plant.frequency_response(OMEGA) * controller.reference_response(OMEGA) / (1 + loop)
    assert np.max(np.abs(setpoint - np.exp(-2.0 * s) / (1.2 * s + 1))) < 1e-12


def test_msp_design_nominal_setpoint_response_is_first_order():
    model = IntegratingModel(gain=0.5, dead_time=3.0)
    controller = msp_design(model, 2.0)
    plant = model.plant()
    s = 1j * OMEGA
    loop = loop_response(plant, controller, OMEGA)
    setpoint = plant.frequency_response(OMEGA) * controller.reference_response(OMEGA) / (1 + loop)
    assert np.max(np.abs(setpoint - np.exp(-3.0 * s) / (2.0 * s + 1))) < 1e-10


def test_pid_design_degenerate_model_is_integral_control():
    """theta = 1 (T1 = T2 = 0): the design tends to the integral controller 1/(mu K D2 s)."""
    model = SOPDTModel(gain=1.0, time_constants=(0.0, 0.0), dead_time=5.0)
    controller = pid_design(model, 2.0)
    s = 1j * OMEGA
    assert np.max(np.abs(controller.feedback_response(OMEGA) * (2.0 * 5.0 * s) - 1)) < 1e-6
