"""The discrete PID laws of a process (Marlin sections 11.4, 12.3, 12.4).

* Unsaturated, for a step of the error the law's output at sample ``k`` is the continuous
  controller's response with its derivative (and, in the series form, everything the lead-lag
  feeds) averaged over the sample ``[t_k, t_k + dt]``: the filter of eq. 12.9 is exact for a held
  input, the backward difference of the filtered error is the mean slope over the sample, and the
  rectangular sum of sample means is the exact integral.  So the law holds the same impulse as the
  continuous controller over every sample (to rounding, 1e-12).
* Anti-windup (external feedback): held at a limit, the integral goes to the limit (Marlin eq.
  12.15: the computed output to the limit plus the proportional action), and the output leaves the
  limit as soon as the error reverses; a law without it (tracking off) stays at the limit for
  hundreds of samples.
* The FPPI: held at a limit, its integral goes to the limit and its model follows the input
  actually applied.  (Its agreement with the continuous loop is in ``test_process_performance.py``.)
* A controller without a discrete law (the MSP) is refused by name.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from envs.process.control_laws import DiscretePID, discrete_law
from envs.systems.controllers import FPPI, MSP, PID, SeriesPID

DT = 0.05


def _mean(function, t: np.ndarray) -> np.ndarray:
    """The mean of ``function`` over each ``[t_k, t_k + DT]`` (Gauss-Legendre, 20 points: exact to rounding
    for these exponentials)."""
    nodes, weights = np.polynomial.legendre.leggauss(20)
    points = t[:, None] + 0.5 * DT * (nodes[None, :] + 1.0)
    return 0.5 * (function(points) * weights[None, :]).sum(axis=1)


@pytest.mark.parametrize("form", ["ideal", "series", "pi"])
def test_the_law_holds_the_continuous_response_averaged_over_each_sample(form):
    kc, ti, td, n = 2.0, 3.0, 0.8, 8.0
    tf = td / n
    controller = {"ideal": PID(kc, ti, td, n), "series": SeriesPID(kc, ti, td, n), "pi": PID(kc, ti)}[form]
    law = DiscretePID(controller, DT, (-math.inf, math.inf))
    law.start(0.0)
    t = np.arange(200) * DT
    outputs = np.array([law.update(1.0, 0.0)[1] for _ in t])
    if form == "ideal":  # K_c (1 + t/T_i + (T_d/T_f) e^{-t/T_f})
        expected = kc * (1.0 + t / ti + _mean(lambda s: td / tf * np.exp(-s / tf), t))
    elif form == "series":  # K_c (p + int_0^t p/T_i), p = 1 + ((T_d - T_f)/T_f) e^{-t/T_f}
        lead = td - tf
        integral = t + lead * (1.0 - np.exp(-t / tf))
        expected = kc * (_mean(lambda s: 1.0 + lead / tf * np.exp(-s / tf), t) + integral / ti)
    else:
        expected = kc * (1.0 + t / ti)
    np.testing.assert_allclose(outputs, expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("controller", [PID(4.0, 10.0, 2.0, 10.0), SeriesPID(4.0, 10.0, 2.0, 10.0)], ids=["ideal", "series"])
def test_external_feedback_keeps_the_integral_at_the_limit(controller):
    def run(tracking: bool) -> tuple[list[float], float]:
        law = DiscretePID(controller, DT, (0.0, 100.0))
        if not tracking:
            law.tracking = 0.0
        law.start(50.0)
        for _ in range(2000):  # 100 s with the output pinned at 100 %
            computed, applied = law.update(20.0, 0.0)
            assert applied == 100.0
        integral = law.integral
        return [law.update(-1.0, 0.0)[1] for _ in range(400)], integral

    released, integral = run(tracking=True)
    assert integral == pytest.approx(100.0, abs=0.01)  # at the limit (eq. 12.15), to e^{-10} of its start after 10 T_i
    assert released[1] < 100.0  # off the limit as soon as the error reverses (after the derivative's kick)
    wound, wound_integral = run(tracking=False)
    assert wound_integral > 100.0 + 300.0 and min(wound[:300]) == 100.0  # without it: wound up, stuck at 100 %


def test_unsaturated_the_tracking_changes_nothing():
    controller = PID(1.5, 4.0, 0.5, 10.0)
    laws = [DiscretePID(controller, DT, (-1e9, 1e9)) for _ in range(2)]
    laws[1].tracking = 0.0
    errors = np.sin(np.arange(500) * 0.07)
    for law in laws:
        law.start(0.0)
    first = [laws[0].update(e, 0.0) for e in errors]
    second = [laws[1].update(e, 0.0) for e in errors]
    assert first == second


def test_the_fppi_does_not_wind_up_and_its_model_sees_the_limit():
    law = discrete_law(FPPI(1.0, 10.0, 2.0, 5.0, 5.0), DT, (0.0, 100.0))
    law.start(50.0)
    for _ in range(4000):  # the set point 200 above a measurement that never moves: pinned at 100 %
        assert law.update(200.0, 0.0)[1] == 100.0
    assert law.integral == pytest.approx(100.0, abs=0.01)
    assert law.model == pytest.approx(1.0 * (100.0 - 50.0), rel=1e-6)  # the model driven by the applied input
    assert law.update(-50.0, 0.0)[1] < 100.0  # off the limit as soon as the error reverses


def test_a_controller_without_a_discrete_law_is_refused():
    with pytest.raises(ValueError, match="controller type 'msp' has no discrete law on a process"):
        discrete_law(MSP(1.0, 2.0, 5.0), DT, (0.0, 1.0))
