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
  ``STEADY_STATE_TOLERANCE`` times the change of the signal.  The window is one time scale ``T``
  (one ``T_ar``).
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


def _optional(value: float | None, name: str) -> float | None:
    return None if value is None else _finite(value, name, positive=True)


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
    """The plant's existing, conservative PI, computed from the TRUE plant.

    Self-regulating plants: a lambda-type rule on the plant's exact moment FOPDT
    (``T_a``, ``D_a = T_ar - T_a``, Gorez-Klan eq. 2-5, 2-6):
    ``T_i = max(T_a, 0.1 T_ar)``, ``K_p = T_i/(K (lambda + D_a))`` with ``lambda = T_ar`` (integral
    gain ``1/(K (T_ar + D_a))``).  Integrating plants (``K_v``; ``T_ar`` of the dynamics additional
    to the integrator): ``K_p = 1/(4 K_v T_ar)``, ``T_i = 8 T_ar``.

    The rule alone gives ``Ms`` of 1.0 to 1.55 on FOPDT plants and up to 1.33 on integrating ones,
    but not on lightly damped or strongly inverse-response shapes.  So the rule is detuned by a
    factor ``c`` (``K_p -> c K_p`` for stable plants; ``K_p -> c K_p``, ``T_i -> T_i/c`` for integrating
    ones) chosen on a grid of 5% steps from ``c = 1e-3`` upwards: the largest ``c <= 1`` such that
    every smaller grid value keeps ``Ms = max |1/(1 + L(i omega))|`` (exact frequency response)
    at most ``max_sensitivity_target``.  On that path from a very detuned (stable) loop the
    Nyquist curve never comes near the critical point, so the result is stable.

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
    kp, ti = (_integrating_rule if plant.integrating else _lambda_rule)(plant, detuning)
    pi = kp[:, None] * (1.0 + 1.0 / (1j * ti[:, None] * omega[None, :]))
    sensitivity = np.max(1.0 / np.abs(1.0 + pi * process[None, :]), axis=1)
    bad = np.flatnonzero(sensitivity > target)
    best = detuning.size - 1 if bad.size == 0 else bad[0] - 1
    if best < 0:
        raise ValueError("no PI with the required maximum sensitivity found")  # pragma: no cover
    return PID(kp=float(kp[best]), ti=float(ti[best]))


def _sensitivity_grid(plant: Plant) -> np.ndarray:
    return np.logspace(-4, 3, 4000) / plant.step_time_scale()


def max_sensitivity(plant: Plant, controller: Controller) -> float:
    """``Ms = max |1/(1 + L(i omega))|`` on 4000 log-spaced points over ``[1e-4, 1e3]/T``."""
    loop = loop_response(plant, controller, _sensitivity_grid(plant))
    return float(np.max(1.0 / np.abs(1.0 + loop)))


def _lambda_rule(plant: Plant, detuning: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p1, p2 = plant.taylor_coefficients()
    residence_time = -p1 if -p1 > 0 else plant.step_time_scale()
    apparent = min(math.sqrt(max(2.0 * p2 - residence_time**2, 0.0)), residence_time)
    ti = max(apparent, 0.1 * residence_time)
    kp = ti / (plant.gain * (2.0 * residence_time - apparent))
    return detuning * kp, np.full_like(detuning, ti)


def _integrating_rule(plant: Plant, detuning: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    scale = plant.step_time_scale()
    return detuning / (4.0 * plant.gain * scale), 8.0 * scale / detuning


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

    with ``c = CONFIDENCE`` and ``tol = STEADY_STATE_TOLERANCE`` times ``|target|`` (or the largest
    ``|signal|`` so far).  Returns ``None`` if no sample qualifies.
    """
    mask = steady_state_mask(timepts, signal, window, target=target)
    hits = np.flatnonzero(mask[start:])
    return int(hits[0]) + start if hits.size else None


def steady_state_mask(timepts: np.ndarray, signal: np.ndarray, window: int, *, target: float | None = None) -> np.ndarray:
    """Per sample, whether the window ending there passes the tests of :func:`steady_state_index`."""
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
    scale = abs(target) if target is not None else np.maximum.accumulate(np.abs(y))[ends]
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
        A stabilizing controller with integral action; default :func:`commissioning_pi`.
    dt : float, optional
        Sample time; default ``T/SAMPLES_PER_RESIDENCE_TIME``, reduced to the smallest dead time
        in the loop if that is shorter.
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
    controller = commissioning_pi(plant) if controller is None else _check_controller(controller)
    scale = plant.step_time_scale()
    dt = _loop_sample_time(plant, controller, dt)
    cap = scale * (MAX_DURATION if max_duration is None else _finite(max_duration, "max_duration", positive=True))
    steps_max = max(int(math.ceil(cap / dt)) + 1, 4)
    noise = _noise(rng, noise_std, steps_max)
    window = _window_samples(scale, dt)
    run = _run_closed_loop(plant, controller, amplitude, noise, dt, window, excursion_limit)
    return _identify_closed_loop(plant, controller, amplitude, run, dt, window, scale)


def _check_controller(controller: Controller) -> Controller:
    if getattr(controller, "integrators", 0) < 1:
        raise ValueError("controller must have integral action (e.g. PID with ti set)")
    return controller


def _loop_sample_time(plant: Plant, controller: Controller, dt: float | None) -> float:
    dt = _sample_time(plant, dt)
    delays = [plant.delay] + [float(d) for d in controller.block().delays]
    positive = [d for d in delays if d > 0]
    return min([dt] + positive)


@dataclass(frozen=True)
class _Run:
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
    plant: Plant, controller: Controller, amplitude: float, run: _Run, dt: float, window: int, scale: float
) -> ClosedLoopStepResult:
    k = run.end
    t, u, y = run.timepts[: k + 1], run.control[: k + 1], run.output[: k + 1]
    common = dict(
        timepts=t,
        control=u,
        output=y,
        true_output=run.true_output[: k + 1],
        duration=float(t[-1]),
        relative_duration=float(t[-1] / scale),
        aborted=run.aborted,
        amplitude=amplitude,
        controller=controller,
        settled=run.settled,
    )
    nan = float("nan")
    empty = dict(
        gain=nan, residence_time=nan, apparent_time_constant=nan, normalized_dead_time=nan, theta=nan,
        fopdt=None, sopdt=None, integrating_model=None,
    )
    if run.aborted or k + 1 < window:
        return ClosedLoopStepResult(**common, **empty)
    drive = _cumulative_integral(t, u) if plant.integrating else u
    final_drive = float(np.mean(drive[-window:]))
    if final_drive == 0.0:
        return ClosedLoopStepResult(**common, **empty)
    moments = closed_loop_moments(t, drive, y, final_drive, amplitude)
    gain = amplitude / final_drive
    return ClosedLoopStepResult(**common, **_moment_models(gain, moments.residence_time, moments.apparent_time_constant, plant.integrating))


def _moment_models(gain: float, residence_time: float, apparent: float, integrating: bool) -> dict:
    nan = float("nan")
    if not residence_time > 0:
        return dict(
            gain=gain, residence_time=residence_time, apparent_time_constant=apparent,
            normalized_dead_time=nan, theta=nan, fopdt=None, sopdt=None, integrating_model=None,
        )
    tau = min(max(1.0 - apparent / residence_time, 0.0), 1.0)
    sopdt = None if integrating else sopdt_from_moments(gain, residence_time, tau)
    return dict(
        gain=gain,
        residence_time=residence_time,
        apparent_time_constant=apparent,
        normalized_dead_time=tau,
        theta=theta_from_tau(tau),
        fopdt=None if integrating else fopdt_from_moments(gain, residence_time, apparent),
        sopdt=sopdt,
        integrating_model=IntegratingModel(gain=gain, dead_time=residence_time) if integrating else None,
    )


def _cumulative_integral(t: np.ndarray, values: np.ndarray) -> np.ndarray:
    increments = 0.5 * (values[1:] + values[:-1]) * np.diff(t)
    return np.concatenate([[0.0], np.cumsum(increments)])
