"""Controllers as discrete laws on a sampled process: anti-windup and a filtered derivative.

The rules, the oracle and the agents design continuous controllers (:mod:`envs.systems.controllers`);
on a process they run as the digital PID of Marlin section 11.4 (eq. 11.4 - 11.6: rectangular integral,
backward-difference derivative), executed once per sample, the output held over the sample (zero-order
hold), with the two practical additions of Marlin ch. 12:

* **anti-reset windup by external feedback** (Marlin section 12.4, Fig. 12.14, eq. 12.14-12.15): the
  integral state is pulled towards the output actually applied (after the limits) with the reset
  time ``T_i`` as its time constant, so that a heater held at 0 or 100 % (the normal case on the
  TCLab) does not wind the integral up.  Unsaturated, the law is the standard one exactly; saturated,
  the integral (``MV*/(T_i s + 1)`` of Fig. 12.14) relaxes to the limit ``MV*`` and the computed
  output to ``MV* + K_c e`` (eq. 12.15), discretized by the rectangular rule of the integral itself
  (eq. 11.5): ``I += (dt/T_i) (K_c e + MV* - v)``, with ``dt/T_i`` capped at 1 for the tracking;
* **the derivative filtered** (Marlin section 12.3, eq. 12.8-12.9): the derivative acts on the error
  through the first-order filter ``1/(T_f s + 1)`` with ``T_f = T_d/n`` (the controller's own
  derivative filter), discretized as eq. 12.9 and initialized to the first value (eq. 12.10), so that
  the quantization steps of a measurement (0.32 degC on the TCLab) do not reach the heater as spikes.

The law acts on the error ``e = r - y``, as the controller of the analysis does (``C_ff = C_fb``:
``deadtime analyze``'s set-point response), derivative included; Marlin's eq. 11.6 puts the
derivative on the measurement to avoid the set-point kick, which the filter bounds here to ``n K_c``
times the step.

:class:`DiscretePID` runs both forms of :mod:`envs.systems.controllers`:

* ideal ``K_c (1 + 1/(T_i s) + T_d s/(1 + T_f s))``: ``v = K_c (e + d) + I``,
  ``I += K_c dt/T_i e``;
* series ``K_c (1 + 1/(T_i s)) (1 + T_d s)/(1 + T_f s)``: the lead-lag
  ``(1 + T_d s)/(1 + T_f s) = 1 + (T_d - T_f) s/(1 + T_f s)`` on the error first, ``p = e + d``, then
  the PI on ``p``: ``v = K_c p + I``, ``I += K_c dt/T_i p``;

with ``d = T_D (e_f[k] - e_f[k-1])/dt`` the backward difference (eq. 11.4) of the filtered error
(``T_D = T_d``, or ``T_d - T_f`` in the series form), and the applied output ``u = clip(v)``.  Without
integral action (``ti=None``) ``I`` stays at the bias.

:class:`DiscreteFPPI` runs Hagglund's FPPI the same way: its PI with the same integral and external
feedback, its model fed the input actually applied, the model's dead time read from its past samples.

References
----------
.. [MA] T. Marlin, "Process Control", section 11.4 (eq. 11.4-11.8, the digital PID), section 12.3
   (eq. 12.8-12.10, the digital filter), section 12.4 (Fig. 12.14, eq. 12.14-12.16, anti-reset windup).
"""

from __future__ import annotations

import math

from envs.systems.controllers import FPPI, PID, Controller, SeriesPID
from envs.validation import require_number

__all__ = ["DiscretePID", "DiscreteFPPI", "discrete_law"]


class DiscretePID:
    """A :class:`~envs.systems.controllers.PID` or :class:`~envs.systems.controllers.SeriesPID` as a
    discrete law with limits (see the module docstring).

    Parameters
    ----------
    controller : PID or SeriesPID
        The continuous design, in the process's engineering units.
    sample_time : float
        ``dt`` of the process.
    limits : (float, float)
        The input limits; the applied output is clipped to them.

    Call :meth:`start` with the bias (the operating input) before the first :meth:`update`.
    """

    def __init__(self, controller: PID | SeriesPID, sample_time: float, limits: tuple[float, float]) -> None:
        if not isinstance(controller, PID | SeriesPID):
            raise ValueError(f"controller must be a PID or SeriesPID, got {type(controller).__name__}")
        self.controller = controller
        self.dt = require_number(sample_time, "sample_time", positive=True)
        self.low, self.high = float(limits[0]), float(limits[1])
        kc, ti, td, n = float(controller.kp), controller.ti, float(controller.td), float(controller.n)
        self.kc = kc
        self.series = isinstance(controller, SeriesPID)
        self.reset_rate = 0.0 if ti is None else self.dt / float(ti)  # K_c dt/T_i per unit K_c e
        self.tracking = min(self.reset_rate, 1.0)  # the rectangular rule of the external feedback (Fig. 12.14)
        filter_time = td / n if td > 0 else 0.0
        self.derivative_time = (td - filter_time) if self.series else td
        self.smoothing = math.exp(-self.dt / filter_time) if filter_time > 0 else 0.0  # A of eq. 12.9
        self.start(0.0)

    def start(self, bias: float) -> None:
        """At rest at the operating point: the integral at ``bias`` (the operating input), the
        filtered error and its previous value at zero (the loop closes with no error: a set-point
        step at the first update reaches the derivative, as in the analysed continuous loop)."""
        self.integral = float(bias)
        self.filtered = 0.0

    def update(self, setpoint: float, measurement: float) -> tuple[float, float]:
        """One execution on this sample's set point and measurement: ``(computed, applied)`` outputs."""
        error = setpoint - measurement
        previous = self.filtered
        filtered = self.smoothing * previous + (1.0 - self.smoothing) * error
        self.filtered = filtered
        derivative = self.derivative_time * (filtered - previous) / self.dt if self.derivative_time > 0 else 0.0
        if self.series:
            proportional = error + derivative
            integrated = proportional
        else:
            proportional, integrated = error + derivative, error
        computed = self.kc * proportional + self.integral
        applied = min(max(computed, self.low), self.high)
        # Marlin eq. 11.5 (rectangular sum) with the external feedback of Fig. 12.14
        self.integral += self.kc * self.reset_rate * integrated + self.tracking * (applied - computed)
        return computed, applied


class DiscreteFPPI:
    """Hagglund's FPPI (:class:`~envs.systems.controllers.FPPI`, Ingimundarson section 4, eq. 13-16)
    as a discrete law with limits.

    At each sample: the correction ``c = F (y - m(t - L_n))`` through the filter ``1/(T_f s + 1)``
    (Marlin eq. 12.9, initialized to its first value, eq. 12.10), the error ``e = r - m - c``, the PI
    ``v = K e + I`` (``K = T_n/(K_n T_r)``, ``T_i = T_n``, eq. 14-15) with the integral and its external
    feedback as :class:`DiscretePID`'s, the output ``u = clip(v)``; then the model
    ``T_n m' = K_n (u - u_0) - m`` advanced over the sample exactly for the held input actually applied
    (so the predictor sees the saturation), and ``m(t - L_n)`` read from the model's past samples,
    linearly interpolated for a dead time between samples.
    """

    def __init__(self, controller: FPPI, sample_time: float, limits: tuple[float, float]) -> None:
        if not isinstance(controller, FPPI):
            raise ValueError(f"controller must be an FPPI, got {type(controller).__name__}")
        self.controller = controller
        self.dt = require_number(sample_time, "sample_time", positive=True)
        self.low, self.high = float(limits[0]), float(limits[1])
        self.kc, self.gain = controller.proportional_gain, controller.gain
        self.reset_rate = self.dt / controller.time_constant
        self.tracking = min(self.reset_rate, 1.0)
        self.model_decay = math.exp(-self.dt / controller.time_constant)  # the model's exact ZOH step
        self.smoothing = math.exp(-self.dt / controller.tf) if controller.tf > 0 else 0.0
        delay = controller.dead_time / self.dt
        self.whole = int(math.floor(delay + 1e-9))
        self.fraction = max(delay - self.whole, 0.0)
        self.start(0.0)

    def start(self, bias: float) -> None:
        """At rest at the operating point: the integral at ``bias``, the model at rest (its past at 0),
        the filter to be set by the first correction."""
        self.bias = self.integral = float(bias)
        self.model = 0.0
        self.history = [0.0] * (self.whole + 2)  # m at the samples k - whole - 1 .. k
        self.correction: float | None = None

    def update(self, setpoint: float, measurement: float) -> tuple[float, float]:
        """One execution on this sample's set point and measurement: ``(computed, applied)`` outputs."""
        past = self.history
        delayed = (1.0 - self.fraction) * past[-1 - self.whole] + self.fraction * past[-2 - self.whole]
        raw = measurement - delayed  # y - m(t - L_n)
        if self.correction is None:
            self.correction = raw
        else:
            self.correction = self.smoothing * self.correction + (1.0 - self.smoothing) * raw
        error = setpoint - self.model - self.correction  # r - m - c
        computed = self.kc * error + self.integral
        applied = min(max(computed, self.low), self.high)
        self.integral += self.kc * self.reset_rate * error + self.tracking * (applied - computed)
        self.model = self.model_decay * self.model + (1.0 - self.model_decay) * self.gain * (applied - self.bias)
        past.append(self.model)
        del past[0]
        return computed, applied


def discrete_law(controller: Controller, sample_time: float, limits: tuple[float, float]) -> DiscretePID | DiscreteFPPI:
    """The discrete law of ``controller`` on a process (PID, series PID, FPPI).

    Raises
    ------
    ValueError
        For a controller without one here (the MSP, a predictor for integrating plants), naming its
        type.
    """
    if isinstance(controller, PID | SeriesPID):
        return DiscretePID(controller, sample_time, limits)
    if isinstance(controller, FPPI):
        return DiscreteFPPI(controller, sample_time, limits)
    kind = controller.to_dict()["type"] if hasattr(controller, "to_dict") else type(controller).__name__
    raise ValueError(f"controller type {kind!r} has no discrete law on a process (only 'pid', 'pid-series' and 'fppi')")
