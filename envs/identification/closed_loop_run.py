"""The run of experiment 1: the plant under its controller, from a set-point step to steady state.

The run is causal and stops at its first event: sample ``k`` aborts if its true output leaves
``[-excursion_limit, excursion_limit]`` or if the loop diverges there (a component of the next
state reaches ``divergence_limit(K)`` (``DIVERGENCE_LIMIT`` scaled by the plant's gain) times the largest input so far, ``max(1, |r|, |n_0|, .., |n_k|)``
with ``n`` the measurement noise; sample ``k`` is then the last with finite outputs), and it
settles if both steady-state tests pass.  The first such sample ends the run (else the cap) and
nothing after it is simulated (the noise is drawn in blocks, see :func:`_run_closed_loop`).

How it is computed.  By default (``method="compiled"``) the run is one compiled call per block of
noise (:func:`envs.simulation._run_kernels._closed_loop_run`).  ``closed_loop_step(...,
method="reference")`` is the readable run it replaced (:func:`_reference_run_closed_loop`): the loop's
:class:`~envs.simulation.runs.LoopRun` continued chunk by chunk over growing horizons
(:func:`~envs.identification.experiment_base.run_until_settled`), the new samples tested by
:class:`~envs.identification.steady_state.SteadyStateTest`.  The two give the same run and result bit for
bit, diverging runs included (``tests/unit/fast_paths/test_closed_loop_run.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.systems.controllers import Controller
from envs.identification.experiment_base import MeasurementNoise, as_noise, excursion_index, ExperimentRun, run_until_settled
from envs.identification.noise import sensor_reading
from envs.simulation.loops import closed_loop_of_block
from envs.systems.plants import Plant
from envs.simulation._run_kernels import ABORTED, NO_EVENT, SETTLED, _closed_loop_run
from envs.simulation.delay_systems import divergence_limit
from envs.simulation.discretization import discretize
from envs.simulation.runs import LoopRun, loop_arrays
from envs.identification.steady_state import SteadyStateTest

__all__: list[str] = []


def _check_method(method: str) -> None:
    if method not in ("compiled", "reference"):
        raise ValueError(f"method must be 'compiled' or 'reference', got {method!r}")


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
    :class:`~envs.simulation.runs.LoopRun` continued ``CHUNK_WINDOWS`` windows at a time over
    horizons that double (:func:`~envs.identification.experiment_base.run_until_settled`), each chunk's
    new samples tested by :class:`~envs.identification.steady_state.SteadyStateTest`.

    The divergence limit of sample ``k`` is ``divergence_limit(K)`` times the largest input up to
    ``k``: each chunk is advanced in parts, a new part at each sample whose noise is larger than
    every input before it.
    """
    run = LoopRun(discretize(system, dt), 2 * _first_steps(window))
    output_test = SteadyStateTest(window, target=amplitude, resolution=noise.quantization)
    drive_test = SteadyStateTest(window)
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
        measured = sensor_reading(y + values[: y.size], noise.quantization)
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
        self.buffers = _RunBuffers(discrete.Phi.shape[0], whole.size, self.offset, discrete.system.n_outputs, 0)
        self.size = noise.size  # the longest run allowed
        self.buffers.peak[0] = max(1.0, abs(self.reference))  # the largest input before any noise

    def advance(self, begin: int, until: int) -> tuple[int, int]:
        """The samples ``begin .. until - 1`` (after those before them), drawing their noise:
        ``(outcome, end)``, ``end`` the sample that settled or aborted, else ``until - 1``."""
        b = self.buffers
        if until > b.size:
            b.grow(min(max(until, 2 * b.size), self.size))
        return _closed_loop_run(
            *self.arrays, self.offset, self.reference, self.noise.first(until), self.noise.quantization, self.limit, b.peak,
            b.x, b.history, b.z, b.measured, b.drive, b.sums, *self.settings, begin, until,
        )  # fmt: skip

    def result(self, outcome: int, end: int) -> _ClosedLoopRun:
        """The signals up to the last sample used, copied out of the buffers of the longest run."""
        b, k = self.buffers, end + 1
        signals = np.arange(k) * self.dt, b.z[:k, 1].copy(), b.measured[:k].copy(), b.z[:k, 0].copy()
        return _ClosedLoopRun(*signals, end, outcome == SETTLED, outcome == ABORTED, b.drive[:k].copy())


def _without_load(arrays: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    """The arrays of :func:`~envs.simulation.runs.loop_arrays` without the columns of the load input
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
    (state, delayed signals, outputs, measurement, drive, running sums, largest input so far), for
    runs of up to ``size`` samples, grown (:meth:`grow`) as the run goes on.

    Uninitialized but for the rows before sample 0 (a run fills each row before it reads it): a
    horizon needs no copy of the earlier ones until the buffers grow, and a run that settles early
    touches the pages of a short run, not those of the longest run allowed.
    """

    def __init__(self, n_states: int, n_delays: int, offset: int, n_outputs: int, size: int) -> None:
        self.size, self.offset = int(size), offset
        self.x = np.zeros(n_states)
        self.history = np.empty((offset + size + 1, n_delays))
        self.history[: offset + 1] = 0.0  # w[k] = 0 for k < 0: the loop starts at rest (every delay >= dt)
        self.z = np.empty((size, n_outputs))
        self.measured, self.drive = np.empty(size), np.empty(size)
        self.sums = np.empty((2, 3, size + 1))
        self.sums[:, :, 0] = 0.0  # the running sums before sample 0
        self.peak = np.ones(1)

    def grow(self, size: int) -> None:
        """Room for ``size`` samples (at least the present), the rows so far copied over (their values)."""
        old, self.size = self.size, int(size)
        history, z, measured, drive, sums = self.history, self.z, self.measured, self.drive, self.sums
        self.history = np.empty((self.offset + self.size + 1, history.shape[1]))
        self.history[: history.shape[0]] = history
        self.z = np.empty((self.size, z.shape[1]))
        self.z[:old] = z
        self.measured, self.drive = np.empty(self.size), np.empty(self.size)
        self.measured[:old], self.drive[:old] = measured, drive
        self.sums = np.empty((2, 3, self.size + 1))
        self.sums[:, :, : old + 1] = sums


def _cumulative_integral(t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Trapezoidal ``int_0^t values``: the drive of an integrating plant as the compiled run forms it
    (the tests hold the two equal, bit for bit)."""
    increments = 0.5 * (values[1:] + values[:-1]) * np.diff(t)
    return np.concatenate([[0.0], np.cumsum(increments)])
