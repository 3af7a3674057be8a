"""Identification experiments on a true plant: simulated, with measurement noise, and timed.

Each experiment is a function ``(plant, rng, ..., noise_std=0.0, dt=None, excursion_limit=None)``
that returns a frozen result holding the sampled signals, the identified quantities, and the
experiment's duration in time units and in units of the plant's time scale ``T_ar``:

1. :func:`closed_loop_step`: set-point step with the plant's commissioning PI
   (:func:`commissioning_pi`), run to steady state; ``K`` (``K_v``), ``T_ar`` (Ingimundarson eq. 10),
   ``T_a`` (Gorez-Klan appendix B), ``tau``, ``theta`` and the SOPDT model (eq. 2-7 .. 2-10).
2. :func:`open_loop_step`: ``T_n`` from the area over ``[0, T_ar]`` (Ingimundarson eq. 11), then on
   to steady state for ``T_f_bar`` (eq. 22) and the process reaction curve (Marlin 6.3).
3. :func:`open_loop_ramp`: ``T_n`` by eq. 12.
4. :func:`open_loop_pulse` (integrating plants): the area ``A`` of eq. 46.
5. :func:`relay_feedback`: ultimate period and gain by the describing function.

Conventions
-----------
* The plant starts at rest; signals are deviation variables and the experiment starts at
  ``t = 0``.  ``control`` is the plant input ``u``, ``output`` the *measured* output
  ``y + n`` and ``true_output`` the noise-free ``y``.
* Measurement noise ``n`` is white, Gaussian, with standard deviation ``noise_std`` per sample of
  ``dt``, held over the sample.  The default ``dt`` is ``T/SAMPLES_PER_RESIDENCE_TIME`` with
  ``T = plant.step_time_scale()`` (``T_ar`` of the true plant when positive), so the noise
  bandwidth is fixed relative to the plant and the results are time-scale invariant.
  Exactly ``n_max`` standard normals are drawn per experiment, where ``n_max`` is the number of
  samples of the longest run allowed, so a seed gives the same noise whatever the noise level.
* Steady state is detected causally (:func:`steady_state_index`): the first time the mean of the
  last window is within ``CONFIDENCE`` standard errors of its target (or of the previous window)
  and the fitted slope is insignificant; without noise, the tolerance floor is
  ``STEADY_STATE_TOLERANCE`` times the change of the signal.  The window is one ``T_ar``: the
  plant's time scale ``T`` in experiment 1, the identified ``T_ar`` (``L_n``) afterwards.
* ``excursion_limit``: if the true output ever leaves ``[-limit, limit]`` the experiment stops
  there, ``aborted`` is True and the quantities that need the missing data are NaN or None.

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control", section 2 and appendix B.
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, sections 2, 4.1 and 5.1.
.. [MA] T. Marlin, "Process Control", section 6.3.
.. [AH] K. J. Astrom, T. Hagglund, "Automatic tuning of simple regulators with specifications on
   phase and amplitude margins", Automatica 20 (1984): relay feedback.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from envs.controllers import PID, Controller
from envs.identification import (
    FOPDTModel,
    IntegratingModel,
    SOPDTModel,
    closed_loop_moments,
    fopdt_from_area,
    fopdt_from_moments,
    integrate,
    mismatch_time,
    pulse_mismatch_area,
    ramp_time_constant,
    reaction_curve_tangent,
    reaction_curve_two_point,
    residence_time_from_area,
    sopdt_from_moments,
    step_time_constant,
    theta_from_tau,
)
from envs.loops import closed_loop, loop_response
from envs.plants import Plant, StateSpace
from envs.simulation import discretize, open_loop_response, simulate

__all__ = [
    "SAMPLES_PER_RESIDENCE_TIME",
    "STEADY_STATE_TOLERANCE",
    "CONFIDENCE",
    "COMMISSIONING_MAX_SENSITIVITY",
    "commissioning_pi",
    "max_sensitivity",
    "steady_state_index",
    "steady_state_mask",
    "ExperimentResult",
    "ClosedLoopStepResult",
    "OpenLoopStepResult",
    "OpenLoopRampResult",
    "OpenLoopPulseResult",
    "RelayResult",
    "closed_loop_step",
    "open_loop_step",
    "open_loop_ramp",
    "open_loop_pulse",
    "relay_feedback",
]

SAMPLES_PER_RESIDENCE_TIME = 200
"""Default samples per time scale ``T`` (``T_ar``); fine enough for ``K``, ``T_ar`` to 1e-3."""
STEADY_STATE_TOLERANCE = 1e-5
"""Noise-free steady-state tolerance, relative to the change of the signal (a resolution)."""
CONFIDENCE = 3.0
"""Standard errors within which a window is "at" its target and "flat"."""
COMMISSIONING_MAX_SENSITIVITY = 1.4
"""Maximum sensitivity ``Ms`` the commissioning PI is detuned to, on the exact frequency response."""
MAX_DURATION = 150.0
"""Default cap of an experiment, in time scales ``T``."""


# --------------------------------------------------------------------------- helpers
def _check_plant(plant: Plant) -> Plant:
    if not isinstance(plant, Plant):
        raise ValueError(f"plant must be an envs.plants.Plant, got {type(plant).__name__}")
    return plant


def _check_rng(rng: np.random.Generator) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def _finite(value: float, name: str, *, positive: bool = False, nonzero: bool = False, nonnegative: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ValueError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if positive and value <= 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if nonzero and value == 0:
        raise ValueError(f"{name} must be non-zero, got {value!r}")
    if nonnegative and value < 0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return value


def _sample_time(plant: Plant, dt: float | None) -> float:
    if dt is None:
        return plant.step_time_scale() / SAMPLES_PER_RESIDENCE_TIME
    return _finite(dt, "dt", positive=True)


def _noise(rng: np.random.Generator, noise_std: float, steps: int) -> np.ndarray:
    return noise_std * rng.standard_normal(steps)


def _excursion_index(true_output: np.ndarray, limit: float | None) -> int | None:
    """Index of the first sample whose true output leaves ``[-limit, limit]``."""
    if limit is None:
        return None
    outside = np.flatnonzero(~(np.abs(true_output) <= limit))
    return int(outside[0]) if outside.size else None


# --------------------------------------------------------------------------- commissioning PI
def commissioning_pi(plant: Plant, max_sensitivity_target: float = COMMISSIONING_MAX_SENSITIVITY) -> PID:
    """The plant's existing, conservative controller, computed from the TRUE plant.

    Self-regulating plants: a lambda-type PI on the plant's exact moment FOPDT
    (``T_a``, ``D_a = T_ar - T_a``, Gorez-Klan eq. 2-5, 2-6):
    ``T_i = max(T_a, 0.1 T_ar)``, ``K_p = T_i/(K (lambda + D_a))`` with ``lambda = T_ar``, so the
    integral gain is ``1/(K (T_ar + D_a))``.

    Integrating plants (velocity gain ``K_v``, ``T_ar`` of the dynamics additional to the
    integrator): proportional only, ``K_p = 1/(3 K_v T_ar)`` (``ti=None``).  The plant's own
    integrator removes the set-point offset, which is all Ingimundarson section 2.3 needs; a PI
    around an integrator adds a slow closed-loop mode (time constant of about ``T_i``, e.g.
    ``8 T_ar`` for ``K_p = 1/(4 K_v T_ar)``, ``T_i = 8 T_ar``) that made the experiment three times
    longer (about 70 instead of 20 ``T_ar`` to settle to 1e-5) and the second moments of
    appendix B far worse conditioned (``g_2 = -T_i/(K_v K_p)``).

    The rule alone gives ``Ms`` of 1.0 to 1.55 on FOPDT plants and about 1.34 on integrating ones,
    but not on lightly damped or strongly inverse-response shapes.  So the gain is detuned by a
    factor ``c`` (``K_p -> c K_p``, ``T_i`` kept) chosen on a grid of 5% steps from ``c = 1e-3``
    upwards: the largest ``c <= 1`` such that every smaller grid value keeps
    ``Ms = max |1/(1 + L(i omega))|`` (exact frequency response, :func:`max_sensitivity` grid) at
    most ``max_sensitivity_target``.  Along that path from an almost open (stable) loop the Nyquist
    curve never comes near the critical point, so the result is stable.

    Raises
    ------
    ValueError
        If ``max_sensitivity_target <= 1``.
    """
    plant = _check_plant(plant)
    target = _finite(max_sensitivity_target, "max_sensitivity_target")
    if target <= 1.0:
        raise ValueError(f"max_sensitivity_target must be > 1, got {target!r}")
    omega = _sensitivity_grid(plant)
    process = plant.frequency_response(omega)
    detuning = np.geomspace(1e-3, 1.0, 139)
    kp, reset_rate = (_integrating_rule if plant.integrating else _lambda_rule)(plant, detuning)
    pi = kp[:, None] * (1.0 + reset_rate / (1j * omega[None, :]))
    sensitivity = np.max(1.0 / np.abs(1.0 + pi * process[None, :]), axis=1)
    bad = np.flatnonzero(sensitivity > target)
    best = detuning.size - 1 if bad.size == 0 else bad[0] - 1
    if best < 0:  # pragma: no cover - a loop detuned 1000 times is far inside the target
        raise ValueError("no PI with the required maximum sensitivity found")
    return PID(kp=float(kp[best]), ti=1.0 / reset_rate if reset_rate > 0 else None)


def _sensitivity_grid(plant: Plant) -> np.ndarray:
    return np.logspace(-4, 3, 2500) / plant.step_time_scale()


def max_sensitivity(plant: Plant, controller: Controller) -> float:
    """``Ms = max |1/(1 + L(i omega))|`` on 2500 log-spaced points over ``[1e-4, 1e3]/T``."""
    loop = loop_response(plant, controller, _sensitivity_grid(plant))
    return float(np.max(1.0 / np.abs(1.0 + loop)))


def _lambda_rule(plant: Plant, detuning: np.ndarray) -> tuple[np.ndarray, float]:
    p1, p2 = plant.taylor_coefficients()
    residence_time = -p1 if -p1 > 0 else plant.step_time_scale()
    apparent = min(math.sqrt(max(2.0 * p2 - residence_time**2, 0.0)), residence_time)
    ti = max(apparent, 0.1 * residence_time)
    kp = ti / (plant.gain * (2.0 * residence_time - apparent))
    return detuning * kp, 1.0 / ti


def _integrating_rule(plant: Plant, detuning: np.ndarray) -> tuple[np.ndarray, float]:
    return detuning / (3.0 * plant.gain * plant.step_time_scale()), 0.0


# --------------------------------------------------------------------------- steady state
def steady_state_index(
    timepts: np.ndarray,
    signal: np.ndarray,
    window: int,
    *,
    target: float | None = None,
    start: int = 0,
) -> int | None:
    """First sample ``k >= start`` at which ``signal`` is in steady state, judged causally.

    Over the window of the last ``window`` samples ending at ``k`` (``n`` samples, length ``W``):

    * noise ``sigma`` is estimated as the RMS of the second differences over ``sqrt(6)``;
    * the fitted slope ``b`` is insignificant: ``|b| W <= c sigma sqrt(12/n) + tol``;
    * with a ``target``: ``|mean - target| <= c sigma/sqrt(n) + tol``; without: the mean equals the
      previous window's, ``|mean_k - mean_{k-n}| <= c sigma sqrt(2/n) + tol``, and differs from the
      initial value 0 by more than ``c sigma/sqrt(n) + tol`` (the response has started);

    with ``c = CONFIDENCE`` and ``tol = STEADY_STATE_TOLERANCE`` times ``|target|`` (or ``|mean|``).
    Returns ``None`` if no sample qualifies.
    """
    mask = steady_state_mask(timepts, signal, window, target=target)
    hits = np.flatnonzero(mask[start:])
    return int(hits[0]) + start if hits.size else None


def steady_state_mask(timepts: np.ndarray, signal: np.ndarray, window: int, *, target: float | None = None) -> np.ndarray:
    """Per sample, whether the window ending there passes the tests of :func:`steady_state_index`.

    The samples are taken as equally spaced (``timepts`` is for the interface's symmetry).
    """
    y = np.asarray(signal, dtype=float)
    n = int(window)
    if n < 3:
        raise ValueError(f"window must be >= 3 samples, got {window!r}")
    mask = np.zeros(y.size, dtype=bool)
    if y.size < n:
        return mask
    ends = np.arange(n - 1, y.size)  # window [k - n + 1, k]
    sums = _window_sums(y, n)
    mean = sums / n
    index = np.arange(y.size, dtype=float)
    centered = _window_sums(index * y, n) - (ends - (n - 1) / 2.0) * sums
    change = centered / (n * (n * n - 1) / 12.0) * (n - 1)  # fitted slope times the window length
    curvature = np.concatenate([[0.0, 0.0], np.diff(y, 2)])
    sigma = np.sqrt(_window_sums(curvature**2, n) / n / 6.0)
    scale = abs(target) if target is not None else np.abs(mean)
    tol = STEADY_STATE_TOLERANCE * scale
    ok = np.abs(change) <= CONFIDENCE * sigma * math.sqrt(12.0 / n) + tol
    if target is not None:
        ok &= np.abs(mean - target) <= CONFIDENCE * sigma / math.sqrt(n) + tol
    else:
        previous = np.concatenate([np.full(n, np.inf), mean[:-n]])
        ok &= np.abs(mean - previous) <= CONFIDENCE * sigma * math.sqrt(2.0 / n) + tol
        ok &= np.abs(mean) > CONFIDENCE * sigma / math.sqrt(n) + tol
    mask[ends] = ok
    return mask


def _window_sums(values: np.ndarray, n: int) -> np.ndarray:
    """Sums over each run of ``n`` consecutive values (one per window end ``k >= n - 1``)."""
    c = np.concatenate([[0.0], np.cumsum(values)])
    return c[n:] - c[:-n]


def _window_samples(scale: float, dt: float) -> int:
    return max(int(round(scale / dt)), 3)


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class ExperimentResult:
    """Signals and cost common to every experiment.

    Attributes
    ----------
    timepts : ndarray
        Sample times from the start of the experiment.
    control : ndarray
        Plant input ``u`` at ``timepts`` (held over each sample unless stated otherwise).
    output : ndarray
        Measured output ``y + n``.
    true_output : ndarray
        Noise-free output ``y``.
    duration : float
        Time spent, from the start to the last sample used (or to the abort).
    relative_duration : float
        ``duration / T`` with ``T = plant.step_time_scale()`` (``T_ar`` of the true plant).
    aborted : bool
        The true output left ``[-excursion_limit, excursion_limit]`` (or the loop diverged).
    """

    timepts: np.ndarray
    control: np.ndarray
    output: np.ndarray
    true_output: np.ndarray
    duration: float
    relative_duration: float
    aborted: bool


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


# --------------------------------------------------------------------------- experiment 1
def closed_loop_step(
    plant: Plant,
    rng: np.random.Generator,
    amplitude: float = 1.0,
    noise_std: float = 0.0,
    controller: Controller | None = None,
    dt: float | None = None,
    excursion_limit: float | None = None,
    max_duration: float | None = None,
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
        A stabilizing controller (of :mod:`envs.controllers`) with integral action, unless the plant
        integrates; default :func:`commissioning_pi`.
    dt : float, optional
        Sample time; default ``T/SAMPLES_PER_RESIDENCE_TIME``, reduced to the smallest dead time
        in the loop if that is shorter (the exact loop simulation needs every delay >= dt).
    excursion_limit : float, optional
        Abort when ``|y|`` exceeds it.
    max_duration : float, optional
        Cap on the experiment, default ``MAX_DURATION`` time scales.

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
        On invalid arguments, e.g. ``"amplitude must be non-zero, got 0.0"``.
    """
    plant, rng = _check_plant(plant), _check_rng(rng)
    amplitude = _finite(amplitude, "amplitude", nonzero=True)
    noise_std = _finite(noise_std, "noise_std", nonnegative=True)
    controller = commissioning_pi(plant) if controller is None else _check_controller(plant, controller)
    scale = plant.step_time_scale()
    dt = _loop_sample_time(plant, controller, dt)
    cap = scale * (MAX_DURATION if max_duration is None else _finite(max_duration, "max_duration", positive=True))
    steps_max = max(int(math.ceil(cap / dt)) + 1, 4)
    noise = _noise(rng, noise_std, steps_max)
    window = _window_samples(scale, dt)
    run = _run_closed_loop(plant, controller, amplitude, noise, dt, window, excursion_limit)
    return _identify_closed_loop(plant, controller, amplitude, run, window, scale)


def _check_controller(plant: Plant, controller: Controller) -> Controller:
    if not hasattr(controller, "block") or not hasattr(controller, "feedback_response"):
        raise ValueError(f"controller must be an envs.controllers controller, got {type(controller).__name__}")
    if controller.integrators < 1 and not plant.integrating:
        raise ValueError("controller must have integral action (e.g. PID with ti set) on a self-regulating plant")
    return controller


def _loop_sample_time(plant: Plant, controller: Controller, dt: float | None) -> float:
    dt = _sample_time(plant, dt)
    delays = [plant.delay] + [float(d) for d in controller.block().delays]
    positive = [d for d in delays if d > 0]
    return min([dt] + positive)


@dataclass(frozen=True)
class _Run:
    """A simulated run: the signals up to the horizon simulated, and the last sample used."""

    timepts: np.ndarray
    control: np.ndarray
    output: np.ndarray
    true_output: np.ndarray
    end: int  # last sample used
    settled: bool
    aborted: bool


def _run_closed_loop(
    plant: Plant,
    controller: Controller,
    amplitude: float,
    noise: np.ndarray,
    dt: float,
    window: int,
    excursion_limit: float | None,
) -> _Run:
    """Simulate over growing horizons (doubling) until steady state, the cap, or an excursion."""
    discrete = discretize(closed_loop(plant, controller), dt)
    steps_max = noise.size
    steps = min(max(16 * window, 64), steps_max)
    while True:
        inputs = np.column_stack([np.full(steps, amplitude), np.zeros(steps), noise[:steps]])
        sim = simulate(discrete, inputs)
        y, u = sim.outputs[:, 0], sim.outputs[:, 1]
        measured = y + noise[:steps]
        finite = int(np.argmax(~np.isfinite(y))) if sim.diverged else steps
        abort = _excursion_index(y[:finite], excursion_limit)
        if sim.diverged and abort is None:
            abort = max(finite - 1, 0)
        settle = _closed_loop_settling(sim.timepts[:finite], u[:finite], measured[:finite], amplitude, window, plant.integrating)
        if abort is not None and (settle is None or abort <= settle):
            return _Run(sim.timepts, u, measured, y, abort, False, True)
        if settle is not None:
            return _Run(sim.timepts, u, measured, y, settle, True, False)
        if steps == steps_max:
            return _Run(sim.timepts, u, measured, y, steps - 1, False, False)
        steps = min(2 * steps, steps_max)


def _closed_loop_settling(
    t: np.ndarray, u: np.ndarray, measured: np.ndarray, amplitude: float, window: int, integrating: bool
) -> int | None:
    """First sample where the measured output is at the set point and the input (its integral
    for an integrating plant) has settled too."""
    drive = _cumulative_integral(t, u) if integrating else u
    both = steady_state_mask(t, measured, window, target=amplitude) & steady_state_mask(t, drive, window)
    hits = np.flatnonzero(both)
    return int(hits[0]) if hits.size else None


def _identify_closed_loop(
    plant: Plant, controller: Controller, amplitude: float, run: _Run, window: int, scale: float
) -> ClosedLoopStepResult:
    record = _record(run, scale)
    common = dict(**record, amplitude=amplitude, controller=controller, settled=run.settled)
    t, u, y = record["timepts"], record["control"], record["output"]
    drive = _cumulative_integral(t, u) if plant.integrating else u
    final_drive = float(np.mean(drive[-window:]))
    if run.aborted or t.size < window or final_drive == 0.0:
        return ClosedLoopStepResult(**common, **_moment_models(float("nan"), float("nan"), float("nan"), plant.integrating))
    moments = closed_loop_moments(t, drive, y, final_drive, amplitude)
    gain = amplitude / final_drive
    return ClosedLoopStepResult(**common, **_moment_models(gain, moments.residence_time, moments.apparent_time_constant, plant.integrating))


def _moment_models(gain: float, residence_time: float, apparent: float, integrating: bool) -> dict:
    """The identified fields of :class:`ClosedLoopStepResult` (NaN and None where undefined)."""
    fields = dict(
        gain=gain, residence_time=residence_time, apparent_time_constant=apparent,
        normalized_dead_time=float("nan"), theta=float("nan"), fopdt=None, sopdt=None, integrating_model=None,
    )
    if not residence_time > 0:  # NaN (aborted) or a plant with lead: no model
        return fields
    tau = min(max(1.0 - apparent / residence_time, 0.0), 1.0)
    fields.update(normalized_dead_time=tau, theta=theta_from_tau(tau))
    if integrating:
        fields.update(integrating_model=IntegratingModel(gain=gain, dead_time=residence_time))
    else:
        fields.update(
            fopdt=fopdt_from_moments(gain, residence_time, apparent),
            sopdt=sopdt_from_moments(gain, residence_time, tau),
        )
    return fields


def _cumulative_integral(t: np.ndarray, values: np.ndarray) -> np.ndarray:
    increments = 0.5 * (values[1:] + values[:-1]) * np.diff(t)
    return np.concatenate([[0.0], np.cumsum(increments)])


# --------------------------------------------------------------------------- open-loop helpers
def _run_open_loop(
    state_space: StateSpace,
    delay: float,
    inputs: np.ndarray,
    noise: np.ndarray,
    dt: float,
    settle,
    excursion_limit: float | None,
    first_horizon: int,
) -> _Run:
    """Simulate ``inputs`` (held per sample) over growing horizons, from ``first_horizon`` samples
    and doubling, until ``settle(t, y)`` returns an index, the cap (``inputs.size`` samples) or an
    excursion of the true output."""
    steps_max = inputs.size
    steps = min(max(first_horizon, 16), steps_max)
    while True:
        y = open_loop_response(state_space, delay, inputs[:steps], dt)
        t = np.arange(steps) * dt
        measured = y + noise[:steps]
        abort = _excursion_index(y, excursion_limit)
        end = settle(t, measured)
        if abort is not None and (end is None or abort <= end):
            return _Run(t, inputs[:steps], measured, y, abort, False, True)
        if end is not None:
            return _Run(t, inputs[:steps], measured, y, end, True, False)
        if steps == steps_max:
            return _Run(t, inputs[:steps], measured, y, steps - 1, False, False)
        steps = min(2 * steps, steps_max)


def _record(run: _Run, scale: float) -> dict:
    """The :class:`ExperimentResult` fields of a run, truncated at its last sample."""
    k = run.end + 1
    t = run.timepts[:k]
    return dict(
        timepts=t,
        control=run.control[:k],
        output=run.output[:k],
        true_output=run.true_output[:k],
        duration=float(t[-1]),
        relative_duration=float(t[-1] / scale),
        aborted=run.aborted,
    )


def _noise_level(signal: np.ndarray) -> float:
    """Robust white-noise standard deviation from fourth differences (MAD/0.6745/sqrt(70)).

    Fourth differences of a smooth signal are of order ``y^(4) dt^4`` (negligible at the sample
    times used here), those of white noise have standard deviation ``sqrt(70) sigma``; the median
    ignores the few samples near kinks (a dead time ending, a relay switching).
    """
    fourth = np.diff(np.asarray(signal, dtype=float), 4)
    return float(np.median(np.abs(fourth)) / 0.6745 / math.sqrt(70.0)) if fourth.size else 0.0


def _smoothing_samples(signal: np.ndarray, change: float, residence_time: float, dt: float) -> int:
    """Samples over which to fit slopes and average for the reaction curve.

    With noise ``sigma`` (estimated by :func:`_noise_level`), the least-squares slope over ``n``
    samples has standard deviation ``sigma sqrt(12/n^3)/dt``; ``n`` is chosen so that this is a tenth
    of the slope scale ``|Delta|/T_ar``, at most ``T_ar/(4 dt)``.  When that asks for 2 samples or
    fewer the data are clean enough for the finite difference and no smoothing (``n = 1``).
    """
    slope_scale = 0.1 * abs(change) / residence_time
    samples = (12.0 * _noise_level(signal) ** 2 / (dt * slope_scale) ** 2) ** (1.0 / 3.0)
    if samples <= 2.0:
        return 1
    return int(min(math.ceil(samples), max(residence_time / (4.0 * dt), 3)))


def _moving_average(signal: np.ndarray, samples: int) -> np.ndarray:
    if samples <= 1:
        return signal
    padded = np.concatenate([np.full(samples // 2, signal[0]), signal, np.full(samples - 1 - samples // 2, signal[-1])])
    return np.convolve(padded, np.ones(samples) / samples, mode="valid")


def _self_regulating(plant: Plant, experiment: str) -> Plant:
    plant = _check_plant(plant)
    if plant.integrating:
        raise ValueError(f"plant must be self-regulating for {experiment} (use open_loop_pulse for an integrating plant)")
    return plant


# --------------------------------------------------------------------------- experiment 2: step
@dataclass(frozen=True)
class OpenLoopStepResult(ExperimentResult):
    """Open-loop step (experiment 2).

    Attributes
    ----------
    height : float
        Step height ``h``.
    settled : bool
        Steady state was reached before the cap (needed for the fields below ``dead_time``).
    area : float
        ``A = int_0^{T_ar} y dt`` (measured output, Ingimundarson eq. 11).
    raw_time_constant : float
        ``T_n = A e/(h K_n)`` (eq. 11), unclipped.
    time_constant, dead_time : float
        ``T_n`` clipped to ``(0, T_ar]`` and ``L_n = T_ar - T_n`` (:func:`~envs.identification.fopdt_from_area`).
    model : FOPDTModel or None
        ``K_n e^{-L_n s}/(T_n s + 1)`` with ``K_n`` and ``T_ar`` as given.
    final_output : float
        Steady-state change ``Delta`` (mean of the measured output over the last window).
    mismatch_time : float
        ``T_f_bar = int_0^{t_f} |y/h - y_n| dt / |K_n|`` (eq. 22).
    tangent_model, two_point_model : FOPDTModel or None
        Marlin's process reaction curve, Methods I and II (section 6.3).
    """

    height: float
    settled: bool
    area: float
    raw_time_constant: float
    time_constant: float
    dead_time: float
    model: FOPDTModel | None
    final_output: float
    mismatch_time: float
    tangent_model: FOPDTModel | None
    two_point_model: FOPDTModel | None


def open_loop_step(
    plant: Plant,
    rng: np.random.Generator,
    height: float,
    residence_time: float,
    gain: float,
    noise_std: float = 0.0,
    dt: float | None = None,
    excursion_limit: float | None = None,
    max_duration: float | None = None,
) -> OpenLoopStepResult:
    """Open-loop step of height ``h``: ``T_n`` (eq. 11), then on to steady state for ``T_f_bar``.

    Parameters
    ----------
    plant : Plant
        The true, self-regulating plant.
    rng : numpy.random.Generator
        Source of the measurement noise.
    height : float
        Step height ``h`` (non-zero).
    residence_time, gain : float
        ``T_ar`` and ``K_n`` from experiment 1 (:func:`closed_loop_step`).
    noise_std, dt, excursion_limit, max_duration
        As in :func:`closed_loop_step`.

    Returns
    -------
    OpenLoopStepResult

    Notes
    -----
    Ingimundarson section 2.3 steps 5-6: ``A = int_0^{T_ar} y dt``, ``T_n`` by eq. 11,
    ``L_n = T_ar - T_n``; section 4.1: the same step run on to steady state gives the mismatch
    ``f = y/h - y_n`` with ``y_n`` the model's step response (eq. 20) and ``T_f_bar = int |f| dt/K_n``
    (eq. 22).  Steady state: two consecutive windows of ``T_ar`` agree and are flat
    (:func:`steady_state_mask`), checked from ``t = 2 T_ar`` on.  The reaction curve (Marlin 6.3)
    uses ``Delta`` = the mean of the last window; on noisy data the tangent's slope is fitted, and
    Method II reads a moving average, over a number of samples chosen from the estimated noise
    (``_smoothing_samples``).
    """
    plant, rng = _self_regulating(plant, "open_loop_step"), _check_rng(rng)
    height = _finite(height, "height", nonzero=True)
    residence_time = _finite(residence_time, "residence_time", positive=True)
    gain = _finite(gain, "gain", nonzero=True)
    noise_std = _finite(noise_std, "noise_std", nonnegative=True)
    dt, scale = _sample_time(plant, dt), plant.step_time_scale()
    steps = _cap_steps(scale, dt, max_duration, minimum=2.0 * residence_time)
    noise = _noise(rng, noise_std, steps)
    window = _window_samples(residence_time, dt)
    start = int(math.ceil(2.0 * residence_time / dt))

    def settle(t: np.ndarray, y: np.ndarray) -> int | None:
        return steady_state_index(t, y, window, start=start)

    state_space, inputs = plant.state_space(), np.full(steps, height)
    run = _run_open_loop(state_space, plant.delay, inputs, noise, dt, settle, excursion_limit, start + 6 * window)
    record = _record(run, scale)
    return OpenLoopStepResult(**record, height=height, settled=run.settled,
                              **_step_identification(record, height, residence_time, gain, window, run.settled))


def _cap_steps(scale: float, dt: float, max_duration: float | None, minimum: float = 0.0) -> int:
    cap = MAX_DURATION if max_duration is None else _finite(max_duration, "max_duration", positive=True)
    return max(int(math.ceil(max(cap * scale, minimum) / dt)) + 1, 4)


def _step_identification(record: dict, height: float, residence_time: float, gain: float, window: int, settled: bool) -> dict:
    t, y = record["timepts"], record["output"]
    nan = float("nan")
    out = dict(area=nan, raw_time_constant=nan, time_constant=nan, dead_time=nan, model=None,
               final_output=nan, mismatch_time=nan, tangent_model=None, two_point_model=None)
    if t[-1] < residence_time:
        return out
    area = integrate(t, y, end=residence_time)
    raw = step_time_constant(area, height, gain)
    model = fopdt_from_area(gain, residence_time, raw)
    out.update(area=area, raw_time_constant=raw, time_constant=model.time_constant, dead_time=model.dead_time, model=model)
    if not settled:
        return out
    final = float(np.mean(y[-window:]))
    out.update(final_output=final, mismatch_time=mismatch_time(t, y / height, model))
    out.update(_reaction_curves(t, y, height, final, residence_time))
    return out


def _reaction_curves(t: np.ndarray, y: np.ndarray, height: float, final: float, residence_time: float) -> dict:
    dt = t[1] - t[0]
    smoothing = _smoothing_samples(y, final, residence_time, dt)
    curves = dict(tangent_model=None, two_point_model=None)
    try:
        curves["tangent_model"] = reaction_curve_tangent(t, y, height, final, window=max(smoothing, 2))
    except ValueError:
        pass
    try:
        curves["two_point_model"] = reaction_curve_two_point(t, _moving_average(y, smoothing), height, final)
    except ValueError:
        pass
    return curves


# --------------------------------------------------------------------------- experiment 3: ramp
@dataclass(frozen=True)
class OpenLoopRampResult(ExperimentResult):
    """Open-loop ramp (experiment 3); ``control`` is the ramp ``h t`` at the sample times.

    Attributes
    ----------
    rate : float
        Ramp rate ``h``.
    area : float
        ``A = int_0^{T_ar} y dt``.
    raw_time_constant : float
        ``T_n = sqrt(A/(h K_n (1/2 - e^{-1})))`` (Ingimundarson eq. 12); 0 if ``A/(h K_n) <= 0``.
    time_constant, dead_time : float
        ``T_n`` clipped to ``(0, T_ar]`` and ``L_n = T_ar - T_n``.
    model : FOPDTModel or None
    """

    rate: float
    area: float
    raw_time_constant: float
    time_constant: float
    dead_time: float
    model: FOPDTModel | None


def open_loop_ramp(
    plant: Plant,
    rng: np.random.Generator,
    rate: float,
    residence_time: float,
    gain: float,
    noise_std: float = 0.0,
    dt: float | None = None,
    excursion_limit: float | None = None,
) -> OpenLoopRampResult:
    """Open-loop ramp of rate ``h`` for ``T_ar``: ``T_n`` by Ingimundarson eq. 12.

    The ramp response of ``G e^{-Ls}`` is the step response of ``G(s)/s e^{-Ls}``: the plant is
    augmented with an integrator at its input (``x' = A x + B z``, ``z' = h``, ``y = C x + D z``) and
    driven by a step of height ``h`` through the exact simulation, so the response is exact.  The
    experiment lasts ``T_ar`` (section 2.2: "The length of the open loop experiment is always
    ``T_ar``").

    Parameters
    ----------
    rate : float
        Ramp rate ``h`` (non-zero).
    residence_time, gain : float
        ``T_ar`` and ``K_n`` from experiment 1.
    """
    plant, rng = _self_regulating(plant, "open_loop_ramp"), _check_rng(rng)
    rate = _finite(rate, "rate", nonzero=True)
    residence_time = _finite(residence_time, "residence_time", positive=True)
    gain = _finite(gain, "gain", nonzero=True)
    noise_std = _finite(noise_std, "noise_std", nonnegative=True)
    dt, scale = _sample_time(plant, dt), plant.step_time_scale()
    steps = int(math.ceil(residence_time / dt - 1e-9)) + 1
    noise = _noise(rng, noise_std, steps)
    y = open_loop_response(_with_input_integrator(plant.state_space()), plant.delay, np.full(steps, rate), dt)
    t = np.arange(steps) * dt
    abort = _excursion_index(y, excursion_limit)
    run = _Run(t, rate * t, y + noise, y, steps - 1 if abort is None else abort, abort is None, abort is not None)
    record = _record(run, scale)
    if abort is not None:
        record.update(duration=float(t[abort]), relative_duration=float(t[abort] / scale))
        nan = float("nan")
        return OpenLoopRampResult(**record, rate=rate, area=nan, raw_time_constant=nan, time_constant=nan, dead_time=nan, model=None)
    record.update(duration=residence_time, relative_duration=residence_time / scale)
    area = integrate(t, record["output"], end=residence_time)
    raw = ramp_time_constant(area, rate, gain)
    model = fopdt_from_area(gain, residence_time, raw)
    return OpenLoopRampResult(**record, rate=rate, area=area, raw_time_constant=raw,
                              time_constant=model.time_constant, dead_time=model.dead_time, model=model)


def _with_input_integrator(ss: StateSpace) -> StateSpace:
    n = ss.A.shape[0]
    A = np.zeros((n + 1, n + 1))
    A[:n, :n] = ss.A
    A[:n, n] = ss.B[:, 0]
    B = np.zeros((n + 1, 1))
    B[n, 0] = 1.0
    C = np.hstack([ss.C, ss.D])
    return StateSpace(A=A, B=B, C=C, D=np.zeros((1, 1)))


# --------------------------------------------------------------------------- experiment 4: pulse
@dataclass(frozen=True)
class OpenLoopPulseResult(ExperimentResult):
    """Open-loop pulse into an integrating plant (experiment 4).

    Attributes
    ----------
    height, pulse_duration : float
        ``h_p`` and ``tau_p``.
    settled : bool
        The output settled at its new level before the cap.
    model : IntegratingModel
        The two-parameter model ``K_n e^{-L_n s}/s`` compared against (from experiment 1).
    area : float
        ``A = int |y - y_n| dt/(h_p tau_p)`` (Ingimundarson eq. 46).
    final_output : float
        New steady level (mean over the last window).
    pulse_model : IntegratingModel or None
        The two-parameter model from the pulse alone: ``K_v = y_f/(h_p tau_p)`` and ``L_n`` by
        eq. 10 with the integrated input ``u_i`` (section 2.1), as in section 5.6.
    """

    height: float
    pulse_duration: float
    settled: bool
    model: IntegratingModel
    area: float
    final_output: float
    pulse_model: IntegratingModel | None


def open_loop_pulse(
    plant: Plant,
    rng: np.random.Generator,
    height: float,
    duration: float,
    gain: float,
    dead_time: float,
    noise_std: float = 0.0,
    dt: float | None = None,
    excursion_limit: float | None = None,
    max_duration: float | None = None,
) -> OpenLoopPulseResult:
    """Pulse of height ``h_p`` and duration ``tau_p`` into an integrating plant; ``A`` of eq. 46.

    Parameters
    ----------
    plant : Plant
        The true, integrating plant.
    height, duration : float
        ``h_p`` (non-zero) and ``tau_p`` (> 0).
    gain, dead_time : float
        ``K_n`` (velocity gain) and ``L_n`` of the two-parameter model, from experiment 1.
    noise_std, dt, excursion_limit, max_duration
        As in :func:`closed_loop_step`; ``dt`` is shrunk so that ``tau_p`` is a whole number of samples.

    Notes
    -----
    Runs until the output is flat at its new level: two consecutive windows of
    ``max(L_n, tau_p)`` agree (:func:`steady_state_mask`), checked after the pulse has ended and one
    more window has passed.  ``A`` integrates ``|y - y_n|`` over the whole record (eq. 45-46), so with
    noise it grows with the duration.
    """
    plant, rng = _check_plant(plant), _check_rng(rng)
    if not plant.integrating:
        raise ValueError("plant must be integrating for open_loop_pulse")
    height = _finite(height, "height", nonzero=True)
    duration = _finite(duration, "duration", positive=True)
    model = IntegratingModel(gain=_finite(gain, "gain", nonzero=True), dead_time=_finite(dead_time, "dead_time", nonnegative=True))
    noise_std = _finite(noise_std, "noise_std", nonnegative=True)
    scale = plant.step_time_scale()
    pulse_samples = max(int(round(duration / _sample_time(plant, dt))), 1)
    dt = duration / pulse_samples
    steps = _cap_steps(scale, dt, max_duration, minimum=3.0 * (duration + model.dead_time))
    noise = _noise(rng, noise_std, steps)
    inputs = np.where(np.arange(steps) < pulse_samples, height, 0.0)
    window = _window_samples(max(model.dead_time, duration), dt)
    start = pulse_samples + window

    def settle(t: np.ndarray, y: np.ndarray) -> int | None:
        return steady_state_index(t, y, window, start=start)

    run = _run_open_loop(plant.state_space(), plant.delay, inputs, noise, dt, settle, excursion_limit, start + 6 * window)
    record = _record(run, scale)
    t, y = record["timepts"], record["output"]
    area = pulse_mismatch_area(t, y, model, height, duration) if run.settled else float("nan")
    final = float(np.mean(y[-window:])) if run.settled else float("nan")
    return OpenLoopPulseResult(**record, height=height, pulse_duration=duration, settled=run.settled, model=model,
                               area=area, final_output=final, pulse_model=_pulse_model(t, y, height, duration, final))


def _pulse_model(t: np.ndarray, y: np.ndarray, height: float, duration: float, final: float) -> IntegratingModel | None:
    if not np.isfinite(final) or final == 0.0:
        return None
    integrated_input = height * np.minimum(t, duration)
    dead_time = residence_time_from_area(t, integrated_input, y, initial=(0.0, 0.0), final=(height * duration, final))
    return IntegratingModel(gain=final / (height * duration), dead_time=max(dead_time, 0.0))


# --------------------------------------------------------------------------- experiment 5: relay
@dataclass(frozen=True)
class RelayResult(ExperimentResult):
    """Relay feedback (experiment 5); ``control`` is the relay output at the sample times.

    Attributes
    ----------
    amplitude, hysteresis : float
        Relay amplitude ``d`` and hysteresis ``epsilon`` (on the control error).
    converged : bool
        The last three periods agreed to ``period_tolerance`` (plus the noise jitter).
    switching_times : ndarray
        Instants at which the relay switched (interpolated between samples).
    ultimate_period : float
        ``T_u``, mean of the last two full periods.
    peak_amplitude : float
        ``a``, half the peak-to-peak measured output over those periods.
    ultimate_gain : float
        ``K_u = 4 d/(pi a)`` (describing function of the relay, Astrom-Hagglund 1984).
    harmonic_amplitude, harmonic_ultimate_gain : float
        The same with ``a`` the amplitude of the first Fourier harmonic of the output over those
        periods, ``4 d/(pi a_1) = 1/|G(i omega)|`` exactly at the oscillation frequency (harmonic
        balance); robust to noise.
    """

    amplitude: float
    hysteresis: float
    converged: bool
    switching_times: np.ndarray
    ultimate_period: float
    peak_amplitude: float
    ultimate_gain: float
    harmonic_amplitude: float
    harmonic_ultimate_gain: float


def relay_feedback(
    plant: Plant,
    rng: np.random.Generator,
    amplitude: float,
    hysteresis: float = 0.0,
    noise_std: float = 0.0,
    dt: float | None = None,
    excursion_limit: float | None = None,
    max_duration: float | None = None,
    period_tolerance: float = 1e-3,
) -> RelayResult:
    """Relay feedback around the plant until the oscillation is periodic: ``T_u`` and ``K_u``.

    The relay output is ``u = sign(K) d s`` with the state ``s = +-1`` acting on the error
    ``e = -y_m`` (set point 0) with hysteresis ``epsilon``: ``s`` switches to ``-1`` when
    ``e < -epsilon`` and to ``+1`` when ``e > epsilon``, starting at ``s = +1`` (the operator knows
    the sign of the process gain, so the loop is negative feedback).
    The plant is time-stepped exactly (zero-order hold, the dead time exact): each switching
    instant is found by linear interpolation of the error between samples, and the plant input
    switches at that instant plus ``L``, inside the sample interval, by an exact sub-step.  So the
    period is accurate to second order in ``dt``.

    The describing function gives ``K_u = 4 d/(pi a)`` and ``T_u`` the period (Astrom-Hagglund
    1984; Marlin section 10.7 for the ultimate gain and period).  For a plant whose output
    oscillation is not sinusoidal this differs from the exact phase crossover: for
    ``K e^{-Ls}/s`` the period is exactly ``4 L`` (the true ``T_u``) but the output is a triangle
    of amplitude ``K d L`` and ``4 d/(pi a) = 4/(pi K L)`` against ``pi/(2 K L)``.  With hysteresis
    the oscillation sits where ``G(i omega) = -(pi a/4 d)(sqrt(1 - (epsilon/a)^2) + i epsilon/a)``,
    below the phase crossover.

    Parameters
    ----------
    plant : Plant
        The true plant.
    rng : numpy.random.Generator
        Source of the measurement noise.
    amplitude : float
        Relay amplitude ``d`` (> 0).
    hysteresis : float
        ``epsilon >= 0``, in output units.
    noise_std, excursion_limit, max_duration
        As in :func:`closed_loop_step`.
    dt : float, optional
        Sample time; default ``T/SAMPLES_PER_RESIDENCE_TIME``, at most ``L/20``.
    period_tolerance : float
        Relative agreement of the last three periods that counts as periodic; widened by the
        switching jitter expected from the estimated noise.  A swing of less than ten noise
        standard deviations (the relay chattering on noise, for want of hysteresis; use
        ``hysteresis`` of a few ``noise_std``) never counts as periodic, and 20 switches within 40
        samples (chattering at the sample rate) stop the experiment unconverged.

    Returns
    -------
    RelayResult
    """
    plant, rng = _check_plant(plant), _check_rng(rng)
    amplitude = _finite(amplitude, "amplitude", positive=True)
    hysteresis = _finite(hysteresis, "hysteresis", nonnegative=True)
    noise_std = _finite(noise_std, "noise_std", nonnegative=True)
    period_tolerance = _finite(period_tolerance, "period_tolerance", positive=True)
    dt, scale = _relay_sample_time(plant, dt), plant.step_time_scale()
    steps = _cap_steps(scale, dt, max_duration)
    noise = _noise(rng, noise_std, steps)
    sign = 1.0 if plant.gain > 0 else -1.0
    relay = _RelaySimulation(plant, dt, amplitude * sign, hysteresis, noise[0])
    aborted = converged = False
    for j in range(1, steps):
        switched = relay.step(noise[j])
        aborted = relay.aborted(excursion_limit)
        converged = not aborted and switched and relay.periodic(period_tolerance)
        if aborted or converged or (switched and relay.unresolved()):
            break
    return _relay_result(relay, scale, amplitude, hysteresis, aborted, converged)


def _relay_sample_time(plant: Plant, dt: float | None) -> float:
    """Default ``T/SAMPLES_PER_RESIDENCE_TIME``, at most ``L/20``: the limit cycle of a plant
    with a short dead time has a period of a few ``L``."""
    if dt is not None:
        return _finite(dt, "dt", positive=True)
    dt = _sample_time(plant, None)
    return min(dt, plant.delay / 20.0) if plant.delay > 0 else dt


class _RelaySimulation:
    """Exact time stepping of ``G e^{-Ls}`` under relay feedback with interpolated switching."""

    def __init__(self, plant: Plant, dt: float, level: float, hysteresis: float, initial_noise: float) -> None:
        ss = plant.state_space()
        self.A, self.B = ss.A, ss.B[:, 0]
        self.C, self.D = ss.C[0], float(ss.D[0, 0])
        self.delay, self.dt, self.level, self.hysteresis = plant.delay, dt, level, hysteresis
        self.full_step = self._propagator(dt)
        self.x = np.zeros(self.A.shape[0])
        self.state = 1.0  # relay output sign
        self.events: list[tuple[float, float]] = [(self.delay, level)]  # plant input changes
        self.next_event = 0
        self.plant_input = 0.0
        if self.delay == 0.0:
            self.plant_input, self.next_event = level, 1
        initial = self.D * self.plant_input
        self.times, self.true, self.measured, self.relay_output = [0.0], [initial], [initial + initial_noise], [level]
        self.switches: list[float] = []

    def _propagator(self, span: float) -> tuple[np.ndarray, np.ndarray]:
        n = self.A.shape[0]
        block = np.zeros((n + 1, n + 1))
        block[:n, :n], block[:n, n] = self.A * span, self.B * span
        e = scipy.linalg.expm(block)
        return e[:n, :n], e[:n, n]

    def _advance(self, x: np.ndarray, start: float, plant_input: float, next_event: int) -> tuple[np.ndarray, float, int]:
        """Exact state at ``start + dt`` through the plant-input events inside the interval."""
        now, end = start, start + self.dt
        while next_event < len(self.events) and self.events[next_event][0] < end - 1e-12 * self.dt:
            when, value = self.events[next_event]
            if when > now:
                phi, gamma = self._propagator(when - now)
                x, now = phi @ x + gamma * plant_input, when
            plant_input, next_event = value, next_event + 1
        if now == start:
            phi, gamma = self.full_step
        else:
            phi, gamma = self._propagator(end - now)
        return phi @ x + gamma * plant_input, plant_input, next_event

    def step(self, noise: float) -> bool:
        """Advance one sample; True if the relay switched."""
        start = self.times[-1]
        saved = (self.x, self.plant_input, self.next_event)
        self.x, self.plant_input, self.next_event = self._advance(saved[0], start, saved[1], saved[2])
        end = start + self.dt
        true = float(self.C @ self.x + self.D * self.plant_input)
        measured = true + noise
        switch = self._crossing(start, self.measured[-1], measured)
        if switch is not None:
            self.state = -self.state
            self.switches.append(switch)
            self.events.append((switch + self.delay, self.state * self.level))
            if switch + self.delay < end - 1e-12 * self.dt:  # dead time shorter than the step
                self.x, self.plant_input, self.next_event = self._advance(saved[0], start, saved[1], saved[2])
                true = float(self.C @ self.x + self.D * self.plant_input)
                measured = true + noise
        self.times.append(end)
        self.true.append(true)
        self.measured.append(measured)
        self.relay_output.append(self.state * self.level)
        return switch is not None

    def _crossing(self, start: float, before: float, after: float) -> float | None:
        """Switching instant if the error ``e = -y_m`` crossed the active threshold."""
        e0, e1 = -before, -after
        threshold = -self.hysteresis if self.state > 0 else self.hysteresis
        crossed = e1 < threshold if self.state > 0 else e1 > threshold
        if not crossed:
            return None
        if (e0 - threshold) * (e1 - threshold) >= 0 or e1 == e0:
            return start + self.dt
        return start + (threshold - e0) / (e1 - e0) * self.dt

    def aborted(self, limit: float | None) -> bool:
        return limit is not None and not abs(self.true[-1]) <= limit

    def unresolved(self) -> bool:
        """The last 20 switches came within 40 samples: the relay chatters at the sample rate
        (no phase crossover to oscillate at, or noise without hysteresis)."""
        return len(self.switches) > 20 and self.switches[-1] - self.switches[-21] < 40.0 * self.dt

    def periodic(self, tolerance: float) -> bool:
        """The last three periods (each between switches of the same direction) agree."""
        if len(self.switches) < 7:  # three periods after the first half period
            return False
        s = np.asarray(self.switches[-5:])
        last = s[2:] - s[:-2]
        return bool(np.ptp(last) <= self._tolerance(tolerance, s[0]) * np.mean(last))

    def _tolerance(self, tolerance: float, since: float) -> float:
        """``tolerance`` plus three times the relative period jitter expected from the noise:
        a switching instant moves by ``sigma/|y'|``, and ``|y'| ~ 2 pi a/T`` for an oscillation of
        amplitude ``a`` and period ``T``."""
        first = int(np.searchsorted(self.times, since))
        y = np.asarray(self.measured[first:])
        noise, spread = _noise_level(y), 0.5 * np.ptp(y) if y.size else 0.0
        if noise == 0.0:
            return tolerance
        if spread <= 10.0 * noise:  # chattering on noise (too little hysteresis): not a limit cycle
            return 0.0
        return tolerance + 3.0 * math.sqrt(2.0) * noise / (2.0 * math.pi * spread)


def _relay_result(
    relay: _RelaySimulation, scale: float, amplitude: float, hysteresis: float, aborted: bool, converged: bool
) -> RelayResult:
    t = np.asarray(relay.times)
    record = dict(
        timepts=t,
        control=np.asarray(relay.relay_output),
        output=np.asarray(relay.measured),
        true_output=np.asarray(relay.true),
        duration=float(t[-1]),
        relative_duration=float(t[-1] / scale),
        aborted=aborted,
    )
    switches = np.asarray(relay.switches)
    return RelayResult(**record, amplitude=amplitude, hysteresis=hysteresis, converged=converged,
                       switching_times=switches, **_relay_estimates(t, record["output"], switches, amplitude))


def _relay_estimates(t: np.ndarray, y: np.ndarray, switches: np.ndarray, amplitude: float) -> dict:
    """Period, peak and first-harmonic amplitudes over the last two full periods."""
    nan = float("nan")
    if switches.size < 5:
        return dict(ultimate_period=nan, peak_amplitude=nan, ultimate_gain=nan, harmonic_amplitude=nan, harmonic_ultimate_gain=nan)
    begin, end = switches[-5], switches[-1]
    period = (end - begin) / 2.0
    inside = (t > begin) & (t < end)
    times = np.concatenate([[begin], t[inside], [end]])
    values = np.concatenate([[np.interp(begin, t, y)], y[inside], [np.interp(end, t, y)]])
    peak = 0.5 * (np.max(values) - np.min(values))
    omega = 2.0 * math.pi / period
    harmonic = abs(np.trapezoid(values * np.exp(-1j * omega * times), times)) * 2.0 / (end - begin)
    return dict(
        ultimate_period=period,
        peak_amplitude=peak,
        ultimate_gain=4.0 * amplitude / (math.pi * peak) if peak > 0 else nan,
        harmonic_amplitude=harmonic,
        harmonic_ultimate_gain=4.0 * amplitude / (math.pi * harmonic) if harmonic > 0 else nan,
    )
