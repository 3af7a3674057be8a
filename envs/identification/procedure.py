"""The seeds' identification procedure: experiment 1, then experiment 2 (stable) or 4 (integrating).

Ingimundarson section 2.3 (stable plants): a closed-loop set-point step with the commissioning PI
gives ``K_n`` and ``T_ar`` (eq. 10), with ``T_a``, ``tau``, ``theta`` and the SOPDT model of
Gorez-Klan (eq. 2-8 .. 2-10, appendix B); an open-loop step then gives ``T_n`` (eq. 11),
``L_n = T_ar - T_n`` and the mismatch area ``T_f_bar`` (eq. 22).  Integrating plants (section 5):
the closed-loop step gives ``K_n`` (velocity gain) and ``L_n = T_ar``, and a pulse gives the area
``A`` of eq. 46.  The paper does not state the pulse length; ``tau_p = L_n/3`` is used, close to
the ``tau_p = 2.2`` with which Table 2 reproduces for ``L_n`` of 6 to 8 (see
``deadtime reproduce ingimundarson-table2``).

Amplitudes are chosen for a unit rise of the output (``1/K_n`` at the plant input; a pulse of
``1/(K_n tau_p)`` into an integrating plant), so that the
noise-to-signal ratio is ``noise_std`` whatever the plant's gain, and the noisy experiment is the
same in every unit of gain and time, of either sign (the closed-loop set-point step is a unit rise
too).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.identification.closed_loop_experiment import ClosedLoopStepResult, closed_loop_step
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.identification.open_loop_experiments import OpenLoopPulseResult, OpenLoopStepResult, open_loop_pulse, open_loop_step
from envs.systems.plants import Plant

__all__ = ["Identification", "identify", "PULSE_LENGTH"]

PULSE_LENGTH = 1.0 / 3.0  # tau_p / L_n


@dataclass(frozen=True)
class Identification:
    """Everything the seeds' procedure identifies, and what it cost.

    Attributes
    ----------
    integrating : bool
        Whether the two-parameter model (eq. 2) was identified instead of the FOPDT model (eq. 1).
    gain : float
        ``K_n``: static gain, or velocity gain for integrating plants.
    residence_time : float
        ``T_ar`` from the closed-loop step (eq. 10); ``L_n`` for integrating plants.
    fopdt : FOPDTModel or None
        ``K_n, T_n, L_n`` from the open-loop step (eq. 11); None for integrating plants.
    sopdt : SOPDTModel or None
        Gorez-Klan's SOPDT model (eq. 2-8) from the closed-loop moments; None if integrating.
    integrating_model : IntegratingModel or None
        ``K_n e^{-L_n s}/s`` (eq. 2, 35); None for stable plants.
    mismatch_time : float
        ``T_f_bar`` of eq. 22 (stable plants), else nan.
    pulse_area : float
        ``A`` of eq. 46 (integrating plants), else nan.
    experiment_time : float
        Total duration of the experiments, in the plant's time units.
    closed_loop, open_loop : experiment results
        The raw experiments (signals included).
    """

    integrating: bool
    gain: float
    residence_time: float
    fopdt: FOPDTModel | None
    sopdt: SOPDTModel | None
    integrating_model: IntegratingModel | None
    mismatch_time: float
    pulse_area: float
    experiment_time: float
    closed_loop: ClosedLoopStepResult
    open_loop: OpenLoopStepResult | OpenLoopPulseResult

    @property
    def relative_experiment_time(self) -> float:
        """Experiment time in units of the identified ``T_ar``."""
        return self.experiment_time / self.residence_time


def identify(plant: Plant, rng: np.random.Generator, noise_std: float = 0.0) -> Identification:
    """Run the seeds' procedure on the true ``plant`` (see the module docstring).

    Raises
    ------
    ValueError
        If the closed-loop experiment fails to identify a usable gain and residence time
        (e.g. it was aborted).
    """
    first = closed_loop_step(plant, rng, amplitude=1.0, noise_std=noise_std)
    if not (np.isfinite(first.gain) and first.gain != 0 and np.isfinite(first.residence_time) and first.residence_time > 0):
        raise ValueError(f"the closed-loop step identified no usable model (gain {first.gain}, T_ar {first.residence_time})")
    height = 1.0 / first.gain  # a unit rise of the output, whatever the sign of the gain
    if plant.integrating:
        model = first.integrating_model
        duration = PULSE_LENGTH * model.dead_time
        second = open_loop_pulse(
            plant, rng, height / duration, duration, model.gain, model.dead_time, noise_std=noise_std
        )  # the pulse raises the output by about 1: K_n h_p tau_p = 1
        return Identification(
            integrating=True,
            gain=model.gain,
            residence_time=first.residence_time,
            fopdt=None,
            sopdt=None,
            integrating_model=model,
            mismatch_time=float("nan"),
            pulse_area=second.area,
            experiment_time=first.duration + second.duration,
            closed_loop=first,
            open_loop=second,
        )
    second = open_loop_step(plant, rng, height, first.residence_time, first.gain, noise_std=noise_std)
    return Identification(
        integrating=False,
        gain=first.gain,
        residence_time=first.residence_time,
        fopdt=second.model,
        sopdt=first.sopdt,
        integrating_model=None,
        mismatch_time=second.mismatch_time,
        pulse_area=float("nan"),
        experiment_time=first.duration + second.duration,
        closed_loop=first,
        open_loop=second,
    )
