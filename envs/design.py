"""The design step: one parameter and an identified model give the controller.

These are the three designs of the papers, shared by the environments, the rules and the oracle:

* :func:`pid_design`: Gorez-Klan's series PID on the SOPDT model, parameter ``mu`` (eq. 3-11);
  the derivative filter is ``T_d/N`` with ``N = DERIVATIVE_FILTER`` (a common industrial value;
  it keeps the high-frequency controller gain at ``N + 1`` times ``K_p``).
* :func:`fppi_design`: Hagglund's FPPI on the FOPDT model, parameter ``T_r``, with ``T_f = T_r``
  (Ingimundarson section 4.3: the optimum of eq. 23-24 has ``T_r = T_f``).
* :func:`msp_design`: the modified Smith predictor on the two-parameter model, parameter ``T_r``
  (section 5), optionally with the PD-type extension (eq. 51).

The agent, the oracle and the environments use the *relative* parameter: ``mu``, ``T_r/T_n`` or
``T_r/L_n`` (:func:`relative_scale`), searched over :data:`PARAMETER_RANGES` on a log scale.

Undefined PID
-------------
Eq. 3-11 sets ``K_i = 1/(mu K D_2)``, which is undefined when the moments give no dead time
(``tau = 0``, hence ``D_2 = T_ar theta^2 = 0``; 5 of 40 random lag-chain plants with a strong lead).
:func:`pid_design` floors the ``D_2`` of that formula at :data:`MIN_RELATIVE_DEAD_TIME` times the
model's ``T_ar``.  The floor changes no design whose ``D_2`` is above it, i.e. none whose moments
see a dead time of 1 % of ``T_ar`` or more (every family draws ``L/T_ar >= 0.05``); below it the
design is the one of a model with that small dead time, and ``mu`` keeps the role of eq. 3-12.
"""

from __future__ import annotations

from envs.systems.controllers import FPPI, MSP, SeriesPID
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel

__all__ = [
    "DERIVATIVE_FILTER",
    "MIN_RELATIVE_DEAD_TIME",
    "PARAMETER_RANGES",
    "STRUCTURES",
    "pid_design",
    "fppi_design",
    "msp_design",
    "design",
    "relative_scale",
]

DERIVATIVE_FILTER = 10.0
MIN_RELATIVE_DEAD_TIME = 0.01  # floor of D_2/T_ar in eq. 3-11 (module docstring)
STRUCTURES = ("pid", "fppi", "msp")

PARAMETER_RANGES: dict[str, tuple[float, float]] = {
    "pid": (0.3, 300.0),
    "fppi": (0.001, 10.0),
    "msp": (0.01, 30.0),
}
"""Range of the relative design parameter of each structure (log scale).

* ``"pid"``: ``mu`` (Gorez-Klan eq. 3-11), dimensionless.
* ``"fppi"``: ``T_r/T_n``, ``T_n`` the model's time constant (``kappa = T_n/T_r``).
* ``"msp"``: ``T_r/L_n``, ``L_n`` the model's dead time.

Measured with a wider search (``mu`` in [0.3, 300], ``T_r/T_n`` in [0.003, 100], ``T_r/L_n`` in
[0.005, 100]) on the 17 benchmark plants and 40 random plants of each family
(``sample_plants(family, 50, 0)[:40]``), noise-free identification, default constraints: every
plant had a feasible design, with optima ``mu`` in [0.45, 105.5], ``T_r/T_n`` in [0.0053, 4.9]
and ``T_r/L_n`` in [0.064, 3.0].  ``mu`` must reach about 30 on Ingimundarson's stable P6
(``0.5/(s+1) + 0.05/(s+0.1)``, lead: the PID is unstable up to ``mu`` = 13 and breaks
``Ms <= 2`` up to 28.5) and 105 on lag-chain plant 28 (strong lead, ``D_2 = 0.007 T_ar``: ``mu``
scales with ``1/D_2``).  The ranges leave a factor of 2 or more beyond every optimum found.  The
MSP's optimum under ``Ms <= 2`` is ``T_r/L_n`` of about 2.3 (the MSP loop has ``Ms`` of
2.2-2.4 for ``T_r/L_n <= 1``, Ingimundarson eq. 47).  These are the ranges open to the agent (``mu``
reaching well beyond 8).
"""


def pid_design(model: SOPDTModel, mu: float, derivative_filter: float = DERIVATIVE_FILTER) -> SeriesPID:
    """Gorez-Klan PID: ``T_i = T_1``, ``T_d = T_2``, ``K_p = T_1/(mu K D_2)`` (eq. 3-11).

    ``D_2`` is floored at ``MIN_RELATIVE_DEAD_TIME * T_ar`` (module docstring, "Undefined PID").
    """
    dead_time = max(model.dead_time, MIN_RELATIVE_DEAD_TIME * model.residence_time)
    return SeriesPID.gorez_klan(model.gain, model.time_constants, dead_time, mu, derivative_filter)


def fppi_design(model: FOPDTModel, tr: float) -> FPPI:
    """FPPI with ``T_i = T_n``, ``kappa = T_n/T_r`` and ``T_f = T_r`` (Ingimundarson eq. 14-15, 4.3)."""
    return FPPI(model.gain, model.time_constant, model.dead_time, tr, tr)


def msp_design(model: IntegratingModel, tr: float, extension: bool = False) -> MSP:
    """MSP with ``K_0 = 1/(2 L_n K_n)``, ``K_r = 1/(K_n T_r)`` (Ingimundarson eq. 36-38, or eq. 51)."""
    return MSP(model.gain, model.dead_time, tr, extension)


def relative_scale(structure: str, model: SOPDTModel | FOPDTModel | IntegratingModel) -> float:
    """The unit of the relative parameter: 1 (PID), ``T_n`` (FPPI) or ``L_n`` (MSP)."""
    if structure == "pid":
        return 1.0
    if structure == "fppi":
        return model.time_constant
    return model.dead_time


def design(structure: str, model: SOPDTModel | FOPDTModel | IntegratingModel, parameter: float):
    """The controller of ``structure`` designed from ``model`` with ``parameter`` (``mu`` or ``T_r``)."""
    if structure == "pid":
        return pid_design(model, parameter)
    if structure == "fppi":
        return fppi_design(model, parameter)
    if structure == "msp":
        return msp_design(model, parameter)
    raise ValueError(f"unknown structure {structure!r}; valid: {', '.join(STRUCTURES)}")
