"""The figures of a loop computed the way a researcher would without deadtime-gym.

This is the yardstick of ``deadtime bench``'s speed ratio: python-control 0.10 with a Padé
approximation of every dead time (``control.pade``), block algebra (``control.feedback``, series
products), ``control.forced_response`` for the unit load and set-point steps and the trapezoidal
rule on ``|e|``, ``control.stability_margins`` for the gain and phase margins, the delay margin as
``min PM_i/omega_i`` over the gain crossovers, ``Ms`` as the largest ``|1/(1 + L)|`` of
``control.frequency_response`` on a log grid, and stability from the closed-loop poles of the
Padé model.  Nothing here calls :mod:`envs`' numerics; the controllers' transfer functions are
written from their parameters (Ingimundarson eq. 13-16 and 35-38, Gorez-Klan eq. 3-11).

The Padé order and the time step set the accuracy; ``deadtime bench`` reports them with the
largest relative IAE error against the fine-step reference (:mod:`agents.bench.fine_step`).  Measured on
the bench's 20 loops (time normalized by ``T_ar``, as :func:`_normalized` does): the largest error
is 0.062 at order 4, 0.035 at 6, 0.021 at 8 and 0.22 at 10, where the realization of a dead-time
compensator's loop (two nearly equal Padé dead times) becomes too ill-conditioned; in raw time units
order 8 already breaks down.  The step hardly matters (``T_ar/50`` to ``T_ar/400``: 0.0212 to
0.0215), so the defaults are the most accurate order, 8, and our own step, ``T_ar/50``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from envs.systems.controllers import FPPI, MSP, PID, Controller, SeriesPID
from envs.systems.plants import Plant

__all__ = ["PADE_ORDER", "SAMPLES_PER_TIME_SCALE", "ReferenceScore", "reference_iae", "reference_score"]

PADE_ORDER = 8
SAMPLES_PER_TIME_SCALE = 50
HORIZON = 40.0  # in plant time scales, doubled until the tail of |e| is negligible
MAX_HORIZON = 1280.0
TAIL_SHARE = 1e-5
MS_POINTS_PER_DECADE = 300


@dataclass(frozen=True)
class ReferenceScore:
    """The python-control figures of one loop (plant time units; ``inf`` when undefined)."""

    stable: bool
    ms: float
    gain_margin: float
    phase_margin_deg: float
    delay_margin: float
    iae_load: float
    iae_setpoint: float
    pade_order: int
    dt: float


def _normalized(plant: Plant, controller: Controller, scale: float) -> tuple[Plant, Controller]:
    """The loop in normalized time ``t/T`` (``s -> s/T``): every time constant and dead time divided by ``T``.

    A careful researcher's step: the realizations of high-order Padé approximants are then far
    better conditioned.  An integrating model's velocity gain is multiplied by ``T``.
    """
    import dataclasses

    powers = lambda coefficients: np.asarray(coefficients) * scale ** -np.arange(len(coefficients) - 1, -1, -1.0)
    num, den = powers(plant.num), powers(plant.den)
    scaled_plant = Plant(tuple(num / den[0]), tuple(den / den[0]), plant.dead_time / scale)
    if isinstance(controller, (PID, SeriesPID)):
        ti = None if controller.ti is None else controller.ti / scale
        return scaled_plant, dataclasses.replace(controller, ti=ti, td=controller.td / scale)
    if isinstance(controller, FPPI):
        times = {name: getattr(controller, name) / scale for name in ("time_constant", "dead_time", "tr", "tf")}
        return scaled_plant, dataclasses.replace(controller, **times)
    if isinstance(controller, MSP):
        return scaled_plant, dataclasses.replace(
            controller, gain=controller.gain * scale, dead_time=controller.dead_time / scale, tr=controller.tr / scale
        )
    raise ValueError(f"no python-control reference for {type(controller).__name__}")


def _delay(delay: float, order: int):
    import control

    if delay == 0:
        return control.tf([1.0], [1.0])
    return control.tf(*control.pade(delay, order))


def _controller(controller: Controller, order: int):
    """The controller as one python-control state-space system with inputs ``r, y`` and output ``u``.

    The dead-time compensators are interconnected from their block diagrams (one model, shared by
    the predictor and the correction), so that no pole-zero cancellation is left to ``minreal``.
    """
    import control

    s = control.tf("s")
    if isinstance(controller, (PID, SeriesPID)):
        kp, ti, td, n = controller.kp, controller.ti, controller.td, controller.n
        integral = 0 if ti is None else 1 / (ti * s)
        if isinstance(controller, SeriesPID):
            c = kp * (1 + integral) * ((td * s + 1) / (td / n * s + 1) if td > 0 else 1)
        else:
            c = kp * (1 + integral + (td * s / (td / n * s + 1) if td > 0 else 0))
        blocks = [
            control.ss(c, inputs="e", outputs="u"),
            control.summing_junction(inputs=["r", "-y"], output="e"),
        ]
    elif isinstance(controller, FPPI):  # Ingimundarson Fig. 4
        gain, tn, ln = controller.gain, controller.time_constant, controller.dead_time
        k = tn / (gain * controller.tr)
        filt = 1 / (controller.tf * s + 1) if controller.tf > 0 else control.tf([1.0], [1.0])
        blocks = [
            control.ss(k * (1 + 1 / (tn * s)), inputs="eps", outputs="u"),
            control.ss(gain / (tn * s + 1), inputs="u", outputs="ym"),
            control.ss(_delay(ln, order), inputs="ym", outputs="ymd"),
            control.ss(filt, inputs="ed", outputs="fe"),
            control.summing_junction(inputs=["y", "-ymd"], output="ed"),
            control.summing_junction(inputs=["r", "-ym", "-fe"], output="eps"),
        ]
    elif isinstance(controller, MSP):  # Ingimundarson Fig. 10
        gain, ln = controller.gain, controller.dead_time
        if controller.extension:
            td = 0.4 * ln
            f = 0.6 / (ln * gain) * (td * s + 1) / (td / 10 * s + 1)
        else:
            f = control.tf([0.5 / (ln * gain)], [1.0])
        blocks = [
            control.ss(control.tf([1 / (gain * controller.tr)], [1.0]), inputs="er", outputs="ur"),
            control.ss(gain / s, inputs="ur", outputs="ym"),
            control.ss(_delay(ln, order), inputs="ym", outputs="ymd"),
            control.ss(f, inputs="ed", outputs="fe"),
            control.summing_junction(inputs=["y", "-ymd"], output="ed"),
            control.summing_junction(inputs=["r", "-ym", "-ed"], output="er"),
            control.summing_junction(inputs=["ur", "-fe"], output="u"),
        ]
    else:
        raise TypeError(f"no python-control reference for {type(controller).__name__}")
    return control.interconnect(blocks, inputs=["r", "y"], outputs="u", name="controller")


def _absolute_area(error: np.ndarray, dt: float) -> float:
    return float(np.trapezoid(np.abs(error), dx=dt))


def _step(system, timepts: np.ndarray, method: str) -> np.ndarray:
    """The output for a unit step at ``t = 0`` sampled at ``timepts``."""
    import control
    import scipy.signal

    if method == "scipy_dlsim":  # exact for a step input: zero-order hold
        dt = timepts[1] - timepts[0]
        discrete = scipy.signal.cont2discrete((system.A, system.B, system.C, system.D), dt, method="zoh")
        return scipy.signal.dlsim(discrete[:4] + (dt,), np.ones_like(timepts))[1].ravel()
    return control.forced_response(system, timepts, np.ones_like(timepts)).outputs


def _iae(load_system, setpoint_system, scale: float, dt: float, method: str = "python_control") -> tuple[float, float]:
    """IAE of ``e = -y`` (load) and ``e = 1 - y`` (set point) from step responses and trapezoids."""
    horizon = HORIZON
    while True:
        timepts = np.arange(0.0, horizon * scale + dt / 2, dt)
        values, settled = [], True
        for system, reference in ((load_system, 0.0), (setpoint_system, 1.0)):
            y = _step(system, timepts, method)
            error = reference - np.asarray(y).ravel()
            total = _absolute_area(error, dt)
            tail = _absolute_area(error[-(timepts.size // 10) :], dt)
            settled &= bool(np.isfinite(total)) and tail <= TAIL_SHARE * total
            values.append(total if np.isfinite(total) else math.inf)
        if settled or horizon >= MAX_HORIZON:
            return values[0], values[1]
        horizon *= 2


def _margins(loop, scale: float) -> tuple[float, float, float, float]:
    """``(Ms, GM, PM in degrees, DM)`` of the loop transfer function."""
    import control

    gm, pm, _, _, wgc, _ = control.stability_margins(loop, returnall=True)
    gm, pm, wgc = np.atleast_1d(gm), np.atleast_1d(pm), np.atleast_1d(wgc)
    above = gm[np.isfinite(gm) & (gm > 1)]
    gain_margin = float(np.min(above)) if above.size else math.inf
    phase_margin = float(pm[np.argmin(np.abs(pm))]) if pm.size else math.inf  # python-control's choice
    # phase margins wrapped to [0, 360) for the delay margin
    dm = [np.deg2rad(p % 360.0) / w for p, w in zip(pm, wgc) if w > 0]
    delay_margin = float(min(dm)) if dm else math.inf
    omega = np.logspace(-4, 4, 8 * MS_POINTS_PER_DECADE) / scale
    response = control.frequency_response(loop, omega)
    ms = float(np.max(np.abs(1 / (1 + response.complex.ravel()))))
    return ms, gain_margin, phase_margin, delay_margin


def _closed_loop(plant: Plant, controller: Controller, pade_order: int):
    """``(loop, plant_system, controller_system)``: the loop has inputs ``r, l`` and output ``y``."""
    import control

    plant_system = control.ss(control.tf(list(plant.num), list(plant.den)) * _delay(plant.dead_time, pade_order))
    ctrl = _controller(controller, pade_order)
    loop = control.interconnect(
        [
            control.ss(plant_system, inputs="up", outputs="y"),
            ctrl,
            control.summing_junction(inputs=["u", "l"], output="up"),
        ],
        inputs=["r", "l"],
        outputs="y",
    )
    return loop, plant_system, ctrl


def reference_iae(
    plant: Plant,
    controller: Controller,
    *,
    pade_order: int = PADE_ORDER,
    samples_per_time_scale: int = SAMPLES_PER_TIME_SCALE,
    method: str = "python_control",
) -> tuple[float, float]:
    """Load and set-point IAE of the Padé loop by ``control.forced_response`` or ``scipy.signal.dlsim`` (ZOH)."""
    if method not in ("python_control", "scipy_dlsim"):
        raise ValueError(f"method must be 'python_control' or 'scipy_dlsim', got {method!r}")
    scale = plant.step_time_scale()
    loop, _, _ = _closed_loop(*_normalized(plant, controller, scale), pade_order)
    load, setpoint = _iae(loop[0, 1], loop[0, 0], 1.0, 1.0 / samples_per_time_scale, method)
    return load * scale, setpoint * scale


def reference_score(
    plant: Plant,
    controller: Controller,
    *,
    pade_order: int = PADE_ORDER,
    samples_per_time_scale: int = SAMPLES_PER_TIME_SCALE,
) -> ReferenceScore:
    """Stability, ``Ms``, margins and IAEs of the loop, python-control style (module docstring).

    The time step is ``T/samples_per_time_scale`` with ``T = plant.step_time_scale()`` (``T_ar``).
    An unstable loop has infinite IAE and undefined (``nan``) margins, as in :func:`envs.analysis.scoring.score`.
    """
    import control

    scale = plant.step_time_scale()
    dt = scale / samples_per_time_scale
    loop, plant_system, ctrl = _closed_loop(*_normalized(plant, controller, scale), pade_order)
    if not np.all(np.real(control.poles(loop)) < 0):
        return ReferenceScore(False, math.nan, math.nan, math.nan, 0.0, math.inf, math.inf, pade_order, dt)
    iae_load, iae_setpoint = _iae(loop[0, 1], loop[0, 0], 1.0, 1.0 / samples_per_time_scale)
    ms, gm, pm, dm = _margins(control.tf(plant_system) * control.tf(-ctrl[0, 1]), 1.0)
    return ReferenceScore(True, ms, gm, pm, dm * scale, iae_load * scale, iae_setpoint * scale, pade_order, dt)
