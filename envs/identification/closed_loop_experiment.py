"""Experiment 1: closed-loop set-point step, identified by the method of moments.

:func:`closed_loop_step` steps the set point of the plant under its commissioning PI
(:func:`~envs.identification.commissioning.commissioning_pi`) or a given controller, runs to steady state
(:func:`~envs.identification.steady_state.steady_state_mask`, window ``T``) and identifies ``K`` (``K_v``),
``T_ar`` (Ingimundarson eq. 10), ``T_a`` (Gorez-Klan appendix B), ``tau``, ``theta`` and the SOPDT
model (eq. 2-7 .. 2-10).

The run is causal and stops at its first event: sample ``k`` aborts if its true output leaves
``[-excursion_limit, excursion_limit]`` or if the loop diverges there (a component of the next
state reaches ``divergence_limit(K)`` (``DIVERGENCE_LIMIT`` scaled by the plant's gain) times the largest input so far, ``max(1, |r|, |n_0|, .., |n_k|)``
with ``n`` the measurement noise; sample ``k`` is then the last with finite outputs), and it
settles if both steady-state tests pass.  The first such sample ends the run (else the cap) and
nothing after it is simulated (the noise is drawn in blocks, see :func:`_run_closed_loop`).

How it is computed.  By default (``method="compiled"``) the run is one compiled call per block of
noise (:func:`envs.simulation._run_kernels._closed_loop_run`).  ``closed_loop_step(...,
method="reference")`` is the readable run it replaced (:func:`_reference_run_closed_loop`): the loop's
:class:`~envs.simulation.delay_systems.LoopRun` continued chunk by chunk over growing horizons
(:func:`~envs.identification.experiment_base.run_until_settled`), the new samples tested by
:class:`~envs.identification.steady_state.SteadyStateTest`.  The two give the same run and result bit for
bit, diverging runs included (``tests/unit/fast_paths/test_closed_loop_run.py``).

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control", section 2 and appendix B.
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, sections 2.1 and 2.3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.identification.commissioning import commissioning_pi
from envs.systems.controllers import Controller
from envs.identification.experiment_base import (
    ExperimentResult,
    cap_steps,
    check_plant,
    check_rng,
    MeasurementNoise,
    as_noise,
    excursion_index,
    measurement_noise,
    record_fields,
    ExperimentRun,
    run_until_settled,
    sample_time,
)
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.identification.moments import closed_loop_moments, fopdt_from_moments, sopdt_from_theta, theta_from_tau
from envs.simulation.loops import closed_loop_of_block
from envs.systems.plants import Plant
from envs.simulation._run_kernels import ABORTED, NO_EVENT, SETTLED, _closed_loop_run
from envs.simulation.delay_systems import LoopRun, discretize, divergence_limit, loop_arrays
from envs.identification.steady_state import SteadyStateTest, window_samples
from envs.validation import require_number

__all__ = ["ClosedLoopStepResult", "closed_loop_step", "identify_closed_loop_step"]


@dataclass(frozen=True)
class ClosedLoopStepResult(ExperimentResult):
    """Closed-loop set-point step (experiment 1).

    Attributes
    ----------
    amplitude : float
        Set-point step ``r``.
    controller : Controller
        The loop's controller.
    settled : bool
        Steady state was reached before the cap.
    gain : float
        ``K = y_f/u_f`` (Gorez-Klan eq. 2-4), or ``K_v = y_f/u_i(t_f)`` if integrating.
    residence_time : float
        ``T_ar`` by Ingimundarson eq. 10 (for an integrating plant: of the dynamics additional to the
        integrator, ``L_n`` of eq. 2).
    apparent_time_constant : float
        ``T_a`` (Gorez-Klan appendix B), clipped to ``[0, T_ar]``.
    normalized_dead_time, theta : float
        ``tau = 1 - T_a/T_ar`` (eq. 2-7) and ``theta`` (eq. 2-10).
    fopdt, sopdt : FOPDTModel or None
        Moment models (eq. 2-1, 2-2/2-8), self-regulating plants only.
    integrating_model : IntegratingModel or None
        ``K_v e^{-T_ar s}/s`` (Ingimundarson eq. 2), integrating plants only.
    """

    amplitude: float
    controller: Controller
    settled: bool
    gain: float
    residence_time: float
    apparent_time_constant: float
    normalized_dead_time: float
    theta: float
    fopdt: FOPDTModel | None
    sopdt: SOPDTModel | None
    integrating_model: IntegratingModel | None


def closed_loop_step(
    plant: Plant,
    rng: np.random.Generator,
    amplitude: float = 1.0,
    noise_std: float = 0.0,
    controller: Controller | None = None,
    dt: float | None = None,
    excursion_limit: float | None = None,
    max_duration: float | None = None,
    *,
    method: str = "compiled",
    disturbances=None,
) -> ClosedLoopStepResult:
    """Set-point step in closed loop, run to steady state, identified by the method of moments.

    Parameters
    ----------
    plant : Plant
        The true plant.
    rng : numpy.random.Generator
        Source of the measurement noise.
    amplitude : float
        Set-point step ``r`` (non-zero).
    noise_std : float
        Measurement noise standard deviation per sample (>= 0).
    controller : Controller, optional
        A stabilizing controller (of :mod:`envs.systems.controllers`) with integral action, unless the plant
        integrates; default :func:`commissioning_pi`.
    dt : float, optional
        Sample time; default ``T/SAMPLES_PER_RESIDENCE_TIME``, reduced to the smallest dead time
        in the loop if that is shorter (the exact loop simulation needs every delay >= dt).
    excursion_limit : float, optional
        Abort when ``|y|`` exceeds it.
    max_duration : float, optional
        Cap on the experiment, default ``MAX_DURATION`` time scales.
    method : {"compiled", "reference"}
        ``"compiled"`` (default) runs the loop in compiled calls; ``"reference"`` runs the readable
        chunked run (see the module docstring), which gives the same result bit for bit, slower.
    disturbances : Disturbances, optional
        Drift and load beyond the white noise (:mod:`envs.identification.disturbances`).

    Returns
    -------
    ClosedLoopStepResult

    Notes
    -----
    The levels before the step are the known steady state ``u_b = y_b = 0``; after it
    ``y_f = r`` (integral action, Ingimundarson section 2.3) and ``u_f`` is the mean of ``u`` over the
    last window.  For an integrating plant the input is replaced by its integral
    ``u_i = int u dt`` (section 2.1).  ``K``: Gorez-Klan eq. 2-4; ``T_ar``: Ingimundarson eq. 10
    (identical to appendix B's ``q_1 - g_1``); ``T_a``: appendix B; ``tau``, ``theta``, SOPDT:
    eq. 2-7 .. 2-10.

    Raises
    ------
    ValueError
        On invalid arguments, e.g. ``"amplitude must be non-zero, got 0.0"``, or an unknown ``method``.
    """
    _check_method(method)
    plant, rng = check_plant(plant), check_rng(rng)
    amplitude = require_number(amplitude, "amplitude", nonzero=True)
    noise_std = require_number(noise_std, "noise_std", nonnegative=True)
    controller = commissioning_pi(plant) if controller is None else _check_controller(plant, controller)
    scale = plant.step_time_scale()
    block = controller.block()  # built once: its delays set dt, then it closes the loop
    dt = _loop_sample_time(plant, block, dt)
    noise = measurement_noise(rng, noise_std, cap_steps(scale, dt, max_duration), disturbances, plant, dt)
    window = window_samples(scale, dt)
    run = _run_closed_loop(plant, controller, amplitude, noise, dt, window, excursion_limit, block=block, method=method)
    return _identify_closed_loop(plant, controller, amplitude, run, window, scale)


def _check_method(method: str) -> None:
    if method not in ("compiled", "reference"):
        raise ValueError(f"method must be 'compiled' or 'reference', got {method!r}")


def _check_controller(plant: Plant, controller: Controller) -> Controller:
    if not hasattr(controller, "block") or not hasattr(controller, "feedback_response"):
        raise ValueError(f"controller must be an envs.systems.controllers controller, got {type(controller).__name__}")
    if controller.integrators < 1 and not plant.integrating:
        raise ValueError("controller must have integral action (e.g. PID with ti set) on a self-regulating plant")
    return controller


def _loop_sample_time(plant: Plant, block, dt: float | None) -> float:
    """The sample time, at most every positive delay of the plant and the controller's ``block()``
    (a negligible plant dead time is simulated as none: :data:`envs.systems.plants.NEGLIGIBLE_DEAD_TIME`)."""
    dt = sample_time(plant, dt)
    delays = [plant.simulation_dead_time] + [float(d) for d in block.delays]
    positive = [d for d in delays if d > 0]
    return min([dt] + positive)


def _run_closed_loop(
    plant: Plant,
    controller: Controller,
    amplitude: float,
    noise: MeasurementNoise | np.ndarray,
    dt: float,
    window: int,
    excursion_limit: float | None,
    block=None,
    method: str = "compiled",
) -> _ClosedLoopRun:
    """Simulate the loop sample by sample until steady state, the cap, an excursion or a divergence.

    ``block`` is ``controller.block()`` if the caller has it; ``noise`` is drawn as the run goes
    (or given, one sample per sample of the longest run allowed).

    Sample ``k`` (inputs ``[amplitude, 0, noise[k]]``) settles if the windows ending at it pass both
    steady-state tests (:func:`~envs.identification.steady_state.steady_state_mask`: the measurement at
    ``amplitude``, the drive steady); it aborts if its true output leaves
    ``[-excursion_limit, excursion_limit]`` or if a component of the next state reaches
    ``divergence_limit(K) * max(1, |amplitude|, max_{j <= k} |noise[j]|)`` (the largest input so far:
    sample ``k`` is the last with finite outputs).  The run ends at the first sample that settles or
    aborts, else at the cap; every test is causal, so that sample and the signals up to it are
    those of simulating and testing any longer run from the start.  The run is compiled
    (:func:`envs.simulation._run_kernels._closed_loop_run`), one call per block of noise drawn
    (``NOISE_BLOCK_WINDOWS`` windows, doubling), or one call if the noise is given or zero;
    ``method="reference"`` runs :func:`_reference_run_closed_loop` instead.
    """
    _check_method(method)
    noise = as_noise(noise)
    system = closed_loop_of_block(plant, controller.block() if block is None else block)
    if method == "reference":
        return _reference_run_closed_loop(plant, system, amplitude, noise, dt, window, excursion_limit)
    run = _CompiledRun(plant.integrating, discretize(system, dt), amplitude, noise, window, excursion_limit, plant.gain)
    begin, size = 0, (max(NOISE_BLOCK_WINDOWS * window, 64) if noise.drawn_as_needed else noise.size)
    while True:
        until = min(begin + size, noise.size)
        outcome, end = run.advance(begin, until)
        if outcome != NO_EVENT or until == noise.size:
            return run.result(outcome, end)
        begin, size = until, 2 * size


def _reference_run_closed_loop(
    plant: Plant,
    system,
    amplitude: float,
    noise: MeasurementNoise,
    dt: float,
    window: int,
    excursion_limit: float | None,
) -> _ClosedLoopRun:
    """``_run_closed_loop(..., method="reference")``: the closed loop ``system`` as a
    :class:`~envs.simulation.delay_systems.LoopRun` continued ``CHUNK_WINDOWS`` windows at a time over
    horizons that double (:func:`~envs.identification.experiment_base.run_until_settled`), each chunk's
    new samples tested by :class:`~envs.identification.steady_state.SteadyStateTest`.

    The divergence limit of sample ``k`` is ``divergence_limit(K)`` times the largest input up to
    ``k``: each chunk is advanced in parts, a new part at each sample whose noise is larger than
    every input before it.
    """
    run = LoopRun(discretize(system, dt), 2 * _first_steps(window))
    output_test, drive_test = SteadyStateTest(window, target=amplitude), SteadyStateTest(window)
    limit = divergence_limit(plant.gain)
    done, peak = 0, max(1.0, abs(float(amplitude)))  # the samples tested, the largest input so far

    def trial(steps: int, horizon: int) -> tuple:  # the run is causal: no sample depends on the horizon
        nonlocal done, peak
        values = noise.first(steps)
        inputs = np.column_stack([np.full(steps, float(amplitude)), np.zeros(steps), values])
        peaks = np.maximum.accumulate(np.concatenate([[peak], np.abs(values[done:])]))[1:]
        rises = np.flatnonzero(peaks[1:] > peaks[:-1]) + done + 1  # the samples that raise the limit
        for end in [*rises.tolist(), steps]:
            sim = run.advance(inputs[:end], limit=limit * peaks[end - 1 - done])
            if sim.diverged:
                break
        peak = peaks[-1]
        y, u = sim.outputs[:, 0], sim.outputs[:, 1]
        measured = y + values[: y.size]
        nonfinite = np.flatnonzero(~np.isfinite(y))
        finite = int(nonfinite[0]) if nonfinite.size else y.size  # a diverging sample's outputs are finite
        abort = excursion_index(y[done:finite], excursion_limit)
        abort = None if abort is None else abort + done
        if sim.diverged and abort is None:
            abort = finite - 1
        drive = _cumulative_integral(sim.timepts[:finite], u[:finite]) if plant.integrating else u[:finite]
        hits = np.flatnonzero(output_test.extend(measured[:finite]) & drive_test.extend(drive))
        settle = int(hits[0]) + done if hits.size else None
        done = finite
        return sim.timepts, u, measured, y, abort, settle

    result = run_until_settled(trial, _first_steps(window), noise.size, chunk=CHUNK_WINDOWS * window)
    k = result.end + 1
    t, u = result.timepts[:k].copy(), result.control[:k].copy()
    drive = _cumulative_integral(t, u) if plant.integrating else u.copy()
    signals = t, u, result.output[:k].copy(), result.true_output[:k].copy()
    return _ClosedLoopRun(*signals, result.end, result.settled, result.aborted, drive)


def _first_steps(window: int) -> int:
    """The first horizon of the reference run, in samples."""
    return max(16 * window, 64)


CHUNK_WINDOWS = 4
"""Windows per chunk of the reference run (that of the closed-loop step before the compiled run)."""

NOISE_BLOCK_WINDOWS = 8
"""Windows of noise drawn for the first call of the run (then twice as many each call): a run that
settles early draws few normals more than it uses, and a long one needs few calls."""


@dataclass(frozen=True)
class _ClosedLoopRun(ExperimentRun):
    """The run with its drive (``u``, or ``_cumulative_integral(timepts, u)`` for an integrating plant)."""

    drive: np.ndarray


class _CompiledRun:
    """The run of :func:`_run_closed_loop` in compiled calls (:func:`envs.simulation._run_kernels._closed_loop_run`),
    each continuing the run in :class:`_RunBuffers`."""

    def __init__(self, integrating, discrete, amplitude, noise, window, excursion_limit, gain=1.0) -> None:
        self.limit = divergence_limit(gain)
        self.arrays = _without_load(loop_arrays(discrete))
        whole = self.arrays[-2]
        self.offset = max([1] + [int(w) + 1 for w in whole])
        self.noise, self.reference, self.dt = noise, float(amplitude), float(discrete.dt)
        limit = 0.0 if excursion_limit is None else float(excursion_limit)
        self.settings = (int(window), bool(integrating), self.dt, limit, excursion_limit is not None)
        self.buffers = _RunBuffers(discrete.Phi.shape[0], whole.size, self.offset, discrete.system.n_outputs, noise.size)
        self.buffers.peak[0] = max(1.0, abs(self.reference))  # the largest input before any noise

    def advance(self, begin: int, until: int) -> tuple[int, int]:
        """The samples ``begin .. until - 1`` (after those before them), drawing their noise:
        ``(outcome, end)``, ``end`` the sample that settled or aborted, else ``until - 1``."""
        b = self.buffers
        return _closed_loop_run(
            *self.arrays, self.offset, self.reference, self.noise.first(until), self.limit, b.peak,
            b.x, b.history, b.z, b.measured, b.drive, b.sums, *self.settings, begin, until,
        )  # fmt: skip

    def result(self, outcome: int, end: int) -> _ClosedLoopRun:
        """The signals up to the last sample used, copied out of the buffers of the longest run."""
        b, k = self.buffers, end + 1
        signals = np.arange(k) * self.dt, b.z[:k, 1].copy(), b.measured[:k].copy(), b.z[:k, 0].copy()
        return _ClosedLoopRun(*signals, end, outcome == SETTLED, outcome == ABORTED, b.drive[:k].copy())


def _without_load(arrays: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    """The arrays of :func:`~envs.simulation.delay_systems.loop_arrays` without the columns of the load input
    (input 1, zero here) in ``Gamma``, ``D11`` and ``D21``, if they are finite.

    Each sum of the recursion starts from ``0.0`` and is never ``-0.0`` (``a + b`` is ``-0.0`` only
    if both are), so the term ``c * 0.0`` (a signed zero for a finite ``c``) leaves it unchanged:
    the sums without these terms are the same, bit for bit, and each sample costs fewer products.
    """
    Phi, Gamma, R, C1, D11, D12, C2, D21, D22, whole, a = arrays
    if Gamma.shape[1] != 3 or not all(np.isfinite(M[:, 1]).all() for M in (Gamma, D11, D21)):
        return arrays
    kept = [np.ascontiguousarray(M[:, ::2]) for M in (Gamma, D11, D21)]  # the columns of inputs 0 and 2
    return Phi, kept[0], R, C1, kept[1], D12, C2, kept[2], D22, whole, a


class _RunBuffers:
    """The arrays :func:`envs.simulation._run_kernels._closed_loop_run` continues from one horizon to the next
    (state, delayed signals, outputs, measurement, drive, running sums, largest input so far), for the
    longest run allowed.

    Uninitialized but for the rows before sample 0 (a run fills each row before it reads it): only
    the pages a run reaches are touched, and a horizon needs no copy of the earlier ones.
    """

    def __init__(self, n_states: int, n_delays: int, offset: int, n_outputs: int, size: int) -> None:
        self.x = np.zeros(n_states)
        self.history = np.empty((offset + size + 1, n_delays))
        self.history[: offset + 1] = 0.0  # w[k] = 0 for k < 0: the loop starts at rest (every delay >= dt)
        self.z = np.empty((size, n_outputs))
        self.measured, self.drive = np.empty(size), np.empty(size)
        self.sums = np.empty((2, 3, size + 1))
        self.sums[:, :, 0] = 0.0  # the running sums before sample 0
        self.peak = np.ones(1)


def _identify_closed_loop(
    plant: Plant, controller: Controller, amplitude: float, run: _ClosedLoopRun, window: int, scale: float
) -> ClosedLoopStepResult:
    # run.drive: u, or for an integrating plant its integral (the sums of _cumulative_integral)
    return identify_closed_loop_step(
        record_fields(run, scale), run.drive, amplitude, controller, run.settled, window, plant.integrating
    )


def identify_closed_loop_step(
    record: dict, drive: np.ndarray, amplitude: float, controller: Controller, settled: bool, window: int, integrating: bool
) -> ClosedLoopStepResult:
    """The result of a closed-loop set-point step from its sampled record (experiment 1's arithmetic).

    Parameters
    ----------
    record : dict
        The :class:`~envs.identification.experiment_base.ExperimentResult` fields (``timepts``,
        ``control``, ``output``, ``true_output``, ``duration``, ``relative_duration``, ``aborted``)
        in deviation variables: the loop at rest at 0 before the step of the set point to
        ``amplitude`` at ``timepts[0]``, the record ending at its steady state.
    drive : ndarray
        ``u``, or for an integrating plant its integral ``u_i = int u dt`` (section 2.1).
    amplitude, controller, settled
        The set-point step, the loop's controller and whether the run settled.
    window : int
        Samples of the last window, whose mean of ``drive`` is ``u_f``.
    integrating : bool
        Whether the plant integrates.

    ``K = r/u_f`` (Gorez-Klan eq. 2-4), ``T_ar`` and ``T_a`` by :func:`closed_loop_moments`
    (Ingimundarson eq. 10, Gorez-Klan appendix B), ``tau``, ``theta`` and the models (eq. 2-7 ..
    2-10); NaN and None where the record cannot give them (aborted, shorter than a window, no drive).
    The simulated experiment (:func:`closed_loop_step`) and a sampled process
    (:mod:`envs.process.procedure`) identify with this same arithmetic.
    """
    common = dict(**record, amplitude=amplitude, controller=controller, settled=settled)
    t, y = record["timepts"], record["output"]
    final_drive = float(np.mean(drive[-window:]))
    if record["aborted"] or t.size < window or final_drive == 0.0:
        return ClosedLoopStepResult(**common, **_moment_models(float("nan"), float("nan"), float("nan"), integrating))
    moments = closed_loop_moments(t, drive, y, final_drive, amplitude)
    gain = amplitude / final_drive
    return ClosedLoopStepResult(**common, **_moment_models(gain, moments.residence_time, moments.apparent_time_constant, integrating))


def _moment_models(gain: float, residence_time: float, apparent: float, integrating: bool) -> dict:
    """The identified fields of :class:`ClosedLoopStepResult` (NaN and None where undefined)."""
    fields = dict(
        gain=gain, residence_time=residence_time, apparent_time_constant=apparent,
        normalized_dead_time=float("nan"), theta=float("nan"), fopdt=None, sopdt=None, integrating_model=None,
    )
    if not residence_time > 0:  # NaN (aborted) or a plant with lead: no model
        return fields
    tau = min(max(1.0 - apparent / residence_time, 0.0), 1.0)
    theta = theta_from_tau(tau)
    fields.update(normalized_dead_time=tau, theta=theta)
    if integrating:
        fields.update(integrating_model=IntegratingModel(gain=gain, dead_time=residence_time))
    else:
        fields.update(
            fopdt=fopdt_from_moments(gain, residence_time, apparent),
            sopdt=sopdt_from_theta(gain, residence_time, theta),  # sopdt_from_moments(gain, residence_time, tau)
        )
    return fields


def _cumulative_integral(t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Trapezoidal ``int_0^t values``: the drive of an integrating plant as the compiled run forms it
    (the tests hold the two equal, bit for bit)."""
    increments = 0.5 * (values[1:] + values[:-1]) * np.diff(t)
    return np.concatenate([[0.0], np.cumsum(increments)])
