"""The per-process oracle: the design parameter that minimizes the cost measured on the process.

:func:`baselines.oracle.oracle` searches the one design parameter of a structure (``mu`` of the
Gorez-Klan PID, ``T_r`` of the FPPI) for the smallest cost on the TRUE plant.  On a process the
truth is only known by running it, so :func:`process_oracle` searches the same parameter with the
same search (:func:`baselines.oracle.search_parameter`: a log grid of ``grid`` points over
:data:`envs.structures.PARAMETER_RANGES`, bounded Brent around the best point, two probes) for the
smallest :func:`envs.process.scoring.process_score`: the process's own set-point and load tests,
under the constraints judged on the identified model (a design infeasible there is not run).  The
designs are those of the environments (:func:`envs.structures.design` on the identified model), so the
oracle bounds every policy that sets that parameter, rules and agents alike, on this process and
with these experiments.  It costs up to ``grid + 16`` designs, each two runs of the process.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from baselines.oracle import search_parameter
from envs.analysis.scoring import Constraints, CostWeights
from envs.structures import PARAMETER_RANGES, STRUCTURES, design, relative_scale
from envs.process.performance import RunProtocol
from envs.process.procedure import ProcessIdentification
from envs.process.protocol import Process
from envs.process.scoring import ProcessScore, process_score
from envs.systems.controllers import Controller

__all__ = ["ProcessOracleResult", "process_oracle"]


@dataclass(frozen=True)
class ProcessOracleResult:
    """The best parameter of one structure on one process.

    ``parameter`` is ``mu`` or ``T_r`` (process time units), ``relative_parameter`` the agent's
    (``mu``, ``T_r/T_n``); ``score`` the process score of ``controller`` at it; ``evaluations`` the
    designs scored.
    """

    structure: str
    parameter: float
    relative_parameter: float
    controller: Controller
    score: ProcessScore
    evaluations: int


def process_oracle(
    process: Process,
    found: ProcessIdentification,
    protocol: RunProtocol,
    structure: str = "pid",
    *,
    constraints: Constraints = Constraints(),
    weights: CostWeights = CostWeights(),
    grid: int = 30,
) -> ProcessOracleResult:
    """The parameter of ``structure`` with the smallest process cost (see the module docstring).

    Raises
    ------
    ValueError
        For a structure of integrating plants (the procedure identifies self-regulating processes
        only) or a grid below 3.
    """
    stable = [name for name, s in STRUCTURES.items() if not s.integrating]
    if structure not in stable:
        raise ValueError(f"structure must be one of {', '.join(stable)} on a self-regulating process, got {structure!r}")
    if int(grid) != grid or grid < 3:
        raise ValueError(f"grid must be an integer >= 3, got {grid!r}")
    identification = found.identification
    model = STRUCTURES[structure].model_of(identification)
    unit = relative_scale(structure, model)

    def cost_of(relative: float) -> ProcessScore:
        controller = design(structure, model, relative * unit)
        return process_score(process, controller, found, protocol, constraints=constraints, weights=weights,
                             test_infeasible=False)

    low, high = PARAMETER_RANGES[structure]
    best, at_best, _, evaluations = search_parameter(cost_of, (math.log(low), math.log(high)), int(grid))
    relative = math.exp(best)
    controller = design(structure, model, relative * unit)
    if at_best.performance is None:  # the least-violating design: run its tests for the table anyway
        at_best = process_score(process, controller, found, protocol, constraints=constraints, weights=weights)
    return ProcessOracleResult(structure, relative * unit, relative, controller, at_best, evaluations)
