"""The papers' fixed identification procedure: experiment 1, then experiment 2 (stable) or 4 (integrating).

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

from dataclasses import dataclass, replace

import numpy as np

from envs.identification.closed_loop_experiment import ClosedLoopStepResult, closed_loop_step
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.identification.open_loop_pulse import OpenLoopPulseResult, open_loop_pulse
from envs.identification.open_loop_step import OpenLoopStepResult, open_loop_step
from envs.systems.plants import Plant

__all__ = ["IdentifiedModels", "Identification", "identify", "experiment_deviation", "usable_closed_loop", "PULSE_LENGTH"]

PULSE_LENGTH = 1.0 / 3.0  # tau_p / L_n


@dataclass(frozen=True)
class IdentifiedModels:
    """The models identified for a plant, and the model errors that the papers' rules tune from.

    What the environments' designs and every rule read (the rules' inputs,
    :class:`baselines.rules.registry.RuleInputs`, are these and the model of the ultimate-gain rules).

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
    """

    integrating: bool
    gain: float
    residence_time: float
    fopdt: FOPDTModel | None
    sopdt: SOPDTModel | None
    integrating_model: IntegratingModel | None
    mismatch_time: float
    pulse_area: float


@dataclass(frozen=True)
class Identification(IdentifiedModels):
    """Everything the fixed procedure identifies (the fields of :class:`IdentifiedModels`), and what it cost.

    Attributes
    ----------
    experiment_time : float
        Total duration of the experiments, in the plant's time units.
    closed_loop, open_loop : experiment results
        The raw experiments (signals included).
    experiment_deviation : float
        ``D_exp = int |y| dt`` of the true output over the experiments (output units times time
        units): the production the experiments disturb (:func:`experiment_deviation`); 0 unless
        asked for (``identify(..., deviation=True)``).
    """

    experiment_time: float
    closed_loop: ClosedLoopStepResult
    open_loop: OpenLoopStepResult | OpenLoopPulseResult
    experiment_deviation: float = 0.0

    @property
    def relative_experiment_time(self) -> float:
        """Experiment time in units of the identified ``T_ar``."""
        return self.experiment_time / self.residence_time


def experiment_deviation(result) -> float:
    """``int |y - y_0| dt`` of an experiment's true output ``y`` about its operating point ``y_0 = 0``
    (trapezoidal rule on its samples): the deviation of production that the experiment causes."""
    y, t = np.abs(result.true_output), result.timepts
    if y.size < 2:
        return 0.0
    step = float(t[1] - t[0])
    if abs(float(t[-1] - t[0]) - step * (t.size - 1)) <= 1e-9 * float(t[-1] - t[0]):  # the experiments' uniform grid
        return step * (float(y.sum()) - 0.5 * float(y[0] + y[-1]))  # the trapezoids, without their temporaries
    return float(np.trapezoid(y, t))


def identify(
    plant: Plant, rng: np.random.Generator, noise_std: float = 0.0, *, amplitude: float = 1.0, disturbances=None,
    attempts: int = 1, deviation: bool = False, quantization: float = 0.0,
) -> Identification:  # fmt: skip
    """Run the fixed procedure on the true ``plant`` (see the module docstring).

    ``amplitude`` scales both experiments (a rise ``a`` of the output instead of 1); ``disturbances``
    (:class:`envs.identification.disturbances.Disturbances`) adds drift or load to their measurements;
    ``attempts`` closed-loop steps at most are run until one identifies a usable model (a drift or a
    load can spoil one), each charged (time and deviation); ``deviation``: compute
    ``experiment_deviation`` (else 0; the cost reads it only when production has a price);
    ``quantization``: the sensor's resolution (:func:`~envs.identification.noise.sensor_reading`; 0: none).

    Raises
    ------
    ProcedureFailed
        If no closed-loop experiment identifies a usable gain and residence time (e.g. it was
        aborted); a ``ValueError`` that tells what the failed steps cost.
    """
    spent = lost = 0.0
    for attempt in range(attempts):
        first = closed_loop_step(plant, rng, amplitude=amplitude, noise_std=noise_std, disturbances=disturbances,
                                 quantization=quantization)
        if usable_closed_loop(first):
            break
        spent, lost = spent + first.duration, lost + (experiment_deviation(first) if deviation else 0.0)
    else:
        raise ProcedureFailed(first, attempts, spent, lost)
    found = _second_experiment(plant, rng, noise_std, amplitude, disturbances, first, quantization)
    if deviation:
        found = replace(found, experiment_deviation=experiment_deviation(first) + experiment_deviation(found.open_loop) + lost)
    if attempt == 0:
        return found
    return replace(found, experiment_time=found.experiment_time + spent)


class ProcedureFailed(ValueError):
    """No closed-loop step of the procedure identified a usable model: ``attempts`` steps ran, taking
    ``experiment_time`` and disturbing ``experiment_deviation`` (0 unless asked for); ``closed_loop``
    is the last."""

    def __init__(self, closed_loop: ClosedLoopStepResult, attempts: int, experiment_time: float,
                 experiment_deviation: float) -> None:  # fmt: skip
        super().__init__(f"the closed-loop step identified no usable model (gain {closed_loop.gain}, "
                         f"T_ar {closed_loop.residence_time})")
        self.closed_loop, self.attempts = closed_loop, attempts
        self.experiment_time, self.experiment_deviation = experiment_time, experiment_deviation


def usable_closed_loop(first: ClosedLoopStepResult) -> bool:
    """Whether a closed-loop step identified a finite non-zero gain and a positive residence time."""
    return bool(np.isfinite(first.gain) and first.gain != 0 and np.isfinite(first.residence_time) and first.residence_time > 0)


def _second_experiment(
    plant: Plant, rng, noise_std: float, amplitude: float, disturbances, first, quantization: float = 0.0
) -> Identification:
    height = amplitude / first.gain  # a rise of the output by the amplitude, whatever the sign of the gain
    if plant.integrating:
        model = first.integrating_model
        duration = PULSE_LENGTH * model.dead_time
        second = open_loop_pulse(
            plant, rng, height / duration, duration, model.gain, model.dead_time, noise_std=noise_std,
            disturbances=disturbances, quantization=quantization,
        )  # the pulse raises the output by about the amplitude: K_n h_p tau_p = a
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
    second = open_loop_step(plant, rng, height, first.residence_time, first.gain, noise_std=noise_std,
                            disturbances=disturbances, quantization=quantization)
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
