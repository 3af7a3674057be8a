"""The design step: one parameter and an identified model give the controller.

These are the three designs of SPEC "Design", shared by the environments, the rules and the oracle:

* :func:`pid_design`: Gorez-Klan's series PID on the SOPDT model, parameter ``mu`` (eq. 3-11);
  the derivative filter is ``T_d/N`` with ``N = DERIVATIVE_FILTER`` (a common industrial value;
  it keeps the high-frequency controller gain at ``N + 1`` times ``K_p``).
* :func:`fppi_design`: Hagglund's FPPI on the FOPDT model, parameter ``T_r``, with ``T_f = T_r``
  (Ingimundarson section 4.3: the optimum of eq. 23-24 has ``T_r = T_f``).
* :func:`msp_design`: the modified Smith predictor on the two-parameter model, parameter ``T_r``
  (section 5), optionally with the PD-type extension (eq. 51).
"""

from __future__ import annotations

from envs.controllers import FPPI, MSP, SeriesPID
from envs.identification import FOPDTModel, IntegratingModel, SOPDTModel

__all__ = ["DERIVATIVE_FILTER", "pid_design", "fppi_design", "msp_design"]

DERIVATIVE_FILTER = 10.0


def pid_design(model: SOPDTModel, mu: float, derivative_filter: float = DERIVATIVE_FILTER) -> SeriesPID:
    """Gorez-Klan PID: ``T_i = T_1``, ``T_d = T_2``, ``K_p = T_1/(mu K D_2)`` (eq. 3-11)."""
    return SeriesPID.gorez_klan(model.gain, model.time_constants, model.dead_time, mu, derivative_filter)


def fppi_design(model: FOPDTModel, tr: float) -> FPPI:
    """FPPI with ``T_i = T_n``, ``kappa = T_n/T_r`` and ``T_f = T_r`` (Ingimundarson eq. 14-15, 4.3)."""
    return FPPI(model.gain, model.time_constant, model.dead_time, tr, tr)


def msp_design(model: IntegratingModel, tr: float, extension: bool = False) -> MSP:
    """MSP with ``K_0 = 1/(2 L_n K_n)``, ``K_r = 1/(K_n T_r)`` (Ingimundarson eq. 36-38, or eq. 51)."""
    return MSP(model.gain, model.dead_time, tr, extension)
