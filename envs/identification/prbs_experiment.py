"""Experiment 6: an open-loop pseudo-random binary sequence, identified by least squares.

:func:`open_loop_prbs` drives the true, self-regulating plant from rest with a maximum-length
binary sequence of levels ``+h`` and ``-h`` around the operating point for one period, and fits
the record by :func:`~envs.identification.least_squares.least_squares_fit` (Marlin section 6.4: "There is
no restriction on the shape of the perturbation"; "It is not necessary that the process regain
steady state at the end of the experiment").  Unlike a step, the output swings around its
operating point instead of moving to a new one, and the record is as long as chosen, not until
steady state.

The sequence: the 4-bit maximum-length shift register (the recursion
``s_k = s_{k-3} XOR s_{k-4}``, from ``s = 1, 1, 1, 1``), period ``2^4 - 1 = 15`` clock intervals, eight
of one level and seven of the other, runs of at most 4 intervals (Soderstrom and Stoica 1989,
section 5.2).  The clock interval is ``T_ar/3`` of the identified ``T_ar``, so one period lasts
``5 T_ar`` and the longest run ``4 T_ar/3``: the sequence excites the band around ``1/T_ar`` where
an FOPDT model's time constant and dead time show.

References
----------
.. [MA] T. Marlin, "Process Control", 2nd ed., section 6.4.
.. [SS] T. Soderstrom, P. Stoica, "System Identification", Prentice Hall 1989, section 5.2
   (pseudorandom binary sequences).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from envs.identification.experiment_base import (
    ExperimentResult,
    ExperimentRun,
    check_rng,
    excursion_index,
    fixed_length_steps,
    measurement_noise,
    record_fields,
    sample_time,
    snap_to_integer,
)
from envs.identification.least_squares import LeastSquaresFit, least_squares_fit
from envs.identification.models import FOPDTModel, SOPDTModel
from envs.simulation.delay_systems import MAX_RUN_SAMPLES
from envs.simulation.open_loop import open_loop_response
from envs.identification.noise import sensor_reading
from envs.systems.plants import Plant
from envs.validation import require_number

__all__ = ["PRBS_CLOCK", "PRBS_REGISTER", "OpenLoopPRBSResult", "open_loop_prbs", "prbs_levels", "fit_record"]

PRBS_REGISTER = 4
"""Bits of the shift register: one period is ``2^4 - 1 = 15`` clock intervals."""
PRBS_CLOCK = 1.0 / 3.0
"""Clock interval of the sequence, in units of the identified ``T_ar``."""


def prbs_levels(bits: int = PRBS_REGISTER) -> np.ndarray:
    """One period of the maximum-length sequence as ``+1``/``-1`` (``2^bits - 1`` values).

    Taps of maximum-length registers (Soderstrom and Stoica 1989, table 5.1): 3 bits ``(3, 2)``,
    4 bits ``(4, 3)``, 5 bits ``(5, 3)``, 6 bits ``(6, 5)``, 7 bits ``(7, 6)``.
    """
    taps = {3: (3, 2), 4: (4, 3), 5: (5, 3), 6: (6, 5), 7: (7, 6)}
    if bits not in taps:
        raise ValueError(f"bits must be one of {', '.join(map(str, taps))}, got {bits!r}")
    first, second = taps[bits]
    register = [1] * bits
    levels = []
    for _ in range(2**bits - 1):
        levels.append(register[-1])
        feedback = register[first - 1] ^ register[second - 1]
        register = [feedback] + register[:-1]
    return np.where(np.array(levels) == 1, 1.0, -1.0)


@dataclass(frozen=True)
class OpenLoopPRBSResult(ExperimentResult):
    """Open-loop PRBS (experiment 6); ``control`` is the sequence at the sample times.

    Attributes
    ----------
    height : float
        Level ``h`` of the sequence (the input is ``+h`` or ``-h``).
    clock : float
        Clock interval, in time units.
    fit : LeastSquaresFit or None
        The least-squares fit of the record (None if the experiment was aborted).
    """

    height: float
    clock: float
    fit: LeastSquaresFit | None

    @property
    def model(self) -> FOPDTModel | SOPDTModel | None:
        """The fitted model (None if there is none)."""
        return None if self.fit is None else self.fit.model


def fit_record(result: ExperimentResult, residence_time: float, order: int = 1) -> LeastSquaresFit | None:
    """:func:`~envs.identification.least_squares.least_squares_fit` of an experiment's record (the input
    ``control``, the measured ``output``), with dead times from 0 to the identified ``T_ar``.

    None if the record is shorter than 8 samples, has no excitation or was aborted.
    """
    t = result.timepts
    if result.aborted or t.size < 8 or not np.any(result.control):
        return None
    dt = float(t[1] - t[0])
    longest = min(int(round(residence_time / dt)), t.size - 3)
    return least_squares_fit(result.control, result.output, dt, order=order, delays=range(0, longest + 1))


def open_loop_prbs(
    plant: Plant,
    rng: np.random.Generator,
    height: float,
    residence_time: float,
    noise_std: float = 0.0,
    dt: float | None = None,
    excursion_limit: float | None = None,
    order: int = 1,
    *,
    disturbances=None,
    quantization: float = 0.0,
) -> OpenLoopPRBSResult:
    """One period of the PRBS of levels ``+-h`` and clock ``T_ar/3``, fitted by least squares.

    Parameters
    ----------
    plant : Plant
        The true, self-regulating plant.
    rng : numpy.random.Generator
        Source of the measurement noise (one child stream, as every experiment).
    height : float
        Level ``h`` (non-zero); ``1/K_n`` moves the output by about ``+-1``.
    residence_time : float
        ``T_ar`` from the closed-loop step: the clock is ``T_ar/3``, the dead times searched ``0 .. T_ar``.
    noise_std, dt, excursion_limit, disturbances, quantization
        As in :func:`~envs.identification.closed_loop_experiment.closed_loop_step`.
    order : {1, 2}
        Of the least-squares model (FOPDT or SOPDT).

    A period longer than :data:`~envs.simulation.delay_systems.MAX_RUN_SAMPLES` samples (an identified
    ``T_ar`` far off, e.g. under a load) stops the sequence there unfinished, as an aborted one (no fit).
    """
    if not isinstance(plant, Plant) or plant.integrating:
        raise ValueError("plant must be a self-regulating envs.systems.plants.Plant for open_loop_prbs")
    rng = check_rng(rng)
    height = require_number(height, "height", nonzero=True)
    residence_time = require_number(residence_time, "residence_time", positive=True)
    noise_std = require_number(noise_std, "noise_std", nonnegative=True)
    dt, scale = sample_time(plant, dt), plant.step_time_scale()
    levels = prbs_levels()
    clock = snap_to_integer(PRBS_CLOCK * residence_time / dt)
    per_clock = max(int(math.ceil(clock)), 1) if clock < MAX_RUN_SAMPLES else MAX_RUN_SAMPLES
    steps, cut = fixed_length_steps(levels.size * per_clock - 1)
    inputs = height * levels[np.arange(steps) // per_clock]  # np.repeat(levels, per_clock), cut at the bound
    sensor = measurement_noise(rng, noise_std, steps, disturbances, plant, dt, quantization)
    noise = sensor.first(steps)
    y = open_loop_response(plant.state_space(), plant.dead_time, inputs, dt)
    abort = excursion_index(y, excursion_limit)
    if abort is None and cut:
        abort = steps - 1
    end = steps - 1 if abort is None else abort
    run = ExperimentRun(np.arange(steps) * dt, inputs, sensor_reading(y + noise, sensor.quantization), y, end, abort is None, abort is not None)
    result = OpenLoopPRBSResult(**record_fields(run, scale), height=height, clock=per_clock * dt, fit=None)
    if abort is not None:
        return result
    fit = fit_record(result, residence_time, order)
    return OpenLoopPRBSResult(**record_fields(run, scale), height=height, clock=per_clock * dt, fit=fit)
