"""IAE for unit load and set-point steps (envs.analysis.performance).

Cross-checks:

* the papers' closed forms: for the FPPI the integrated load error is ``-(T_r + T_f + L_n) K_n``
  (Ingimundarson eq. 24, by the final value theorem, so it holds for any self-regulating plant) and
  the nominal set-point response is ``e^{-L_n s}/(T_r s + 1)`` (eq. 15), whose IAE is ``L_n + T_r``;
  the same set-point IAE for the nominal MSP (eq. 37); the integrated load error of a PI(D) is
  ``-T_i/K_p`` and that of the MSP ``-(T_r + L_n)/K_0`` (final value theorem with eq. 36-38, 51);
* ``iae`` and the IAE of ``closed_loop_response`` against an independent RK4 fine-step simulation
  (:func:`agents.bench.fine_step.fine_step_response`, the bench's yardstick) within 0.5% (measured:
  <= 1.3e-4; the reference's own IAE error at these steps, measured in the test by halving its
  step, is below 1e-5 relative);
* ``integrated_absolute_error`` is exact for piecewise-linear signals, zero crossings included.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.bench.fine_step import absolute_area, fine_step_response
from envs.analysis.loop_analysis import analyze
from envs.systems.controllers import FPPI, MSP, PID, SeriesPID
from envs.simulation.loops import closed_loop_response, simulation_step
from envs.analysis.performance import SETTLED_SHARE, iae, iae_batch, integrated_absolute_error
from envs.systems.plants import Plant


def _load_error(plant, controller, horizon=60.0):
    """Sampled error after a unit load step, over ``horizon`` time scales at the scoring step."""
    dt = simulation_step(plant, controller)
    steps = int(math.ceil(horizon * plant.step_time_scale() / dt)) + 1
    return closed_loop_response(plant, controller, steps, dt, load=1.0).error, dt


# ----------------------------------------------------------------------------- closed forms
FPPI_ROWS = {
    # name: (K_n, T_n, L_n, T_r, T_f); the true plant equals the model
    "design-tf-equals-tr": (1.7, 3.0, 1.4, 0.9, 0.9),
    "unfiltered-ppi": (1.7, 3.0, 1.4, 0.9, 0.0),
    "slow-filter": (1.7, 3.0, 1.4, 0.5, 1.5),
    "dead-time-dominant-negative-gain": (-2.0, 1.0, 3.0, 2.0, 2.0),
    "lag-dominant": (0.4, 10.0, 0.5, 2.0, 1.0),
}


@pytest.mark.parametrize("name", FPPI_ROWS)
def test_fppi_nominal_iae_closed_forms(name):
    """Load: ``int e dt = -(T_r + T_f + L_n) K_n`` (eq. 24) and, as ``e`` keeps one sign,
    ``IAE = (T_r + T_f + L_n) |K_n|``.  Set point: ``IAE = L_n + T_r`` (eq. 15, monotone response).

    The trapezoidal rule on samples ``dt`` apart errs by ``O(dt^2/T_r)`` on the set-point error
    (``e`` bends on the time scale ``T_r`` after the kink at ``t = L_n``): at the scoring step
    ``T_ar/50`` that is within 2e-3 here (measured <= 7.4e-4 for ``dt/T_r = 0.1``), and the error
    falls ~16-fold at ``T_ar/200``.  The load integral over 60 time scales comes out exact to
    ~1e-12; ``iae`` stops where its settling test holds, which truncates it by up to about
    ``SETTLED_SHARE`` (1e-5) relative."""
    gain, tn, ln, tr, tf = FPPI_ROWS[name]
    plant, controller = Plant.from_time_constants(gain, [tn], ln), FPPI(gain, tn, ln, tr, tf)
    error, dt = _load_error(plant, controller)
    expected_load = (tr + tf + ln) * gain
    assert np.trapezoid(error, dx=dt) == pytest.approx(-expected_load, rel=1e-6)
    result = iae(plant, controller)
    assert result.settled
    assert result.load == pytest.approx(abs(expected_load), rel=2 * SETTLED_SHARE)
    assert result.setpoint == pytest.approx(ln + tr, rel=2e-3)
    finer = iae(plant, controller, samples_per_residence_time=200)
    assert abs(finer.setpoint - (ln + tr)) < abs(result.setpoint - (ln + tr)) / 10 + 1e-12


def test_fppi_load_integral_holds_with_model_mismatch():
    """Eq. 24 comes from the final value theorem (``int e = -1/K_i`` of ``C_fb``), so it holds
    for any self-regulating plant with ``K_n`` the model's gain."""
    plant = Plant.from_time_constants(1.0, [1.0, 0.5, 0.2], 0.4, zero_time_constants=[-0.3])
    controller = FPPI(1.0, 1.1, 1.2, 1.3, 0.7)
    error, dt = _load_error(plant, controller)
    assert np.trapezoid(error, dx=dt) == pytest.approx(-(1.3 + 0.7 + 1.2) * 1.0, rel=1e-6)


@pytest.mark.parametrize("controller", [PID(0.8, 1.5), PID(1.2, 2.0, 0.4, 8.0), SeriesPID(0.7, 1.8, 0.5, 10.0)], ids=["pi", "pid", "series-pid"])
def test_pid_load_integral_is_ti_over_kp(controller):
    """Final value theorem: ``int e dt = -1/K_i``, ``K_i = kp/ti`` for both PID forms."""
    plant = Plant.from_time_constants(1.5, [1.0, 0.4], 0.6)
    error, dt = _load_error(plant, controller)
    assert np.trapezoid(error, dx=dt) == pytest.approx(-controller.ti / controller.kp, rel=1e-6)


@pytest.mark.parametrize("extension", [False, True])
def test_msp_nominal_iae_closed_forms(extension):
    """Nominal MSP on ``K_n e^{-L_n s}/s``: set-point IAE ``L_n + T_r`` (eq. 37); load integral
    ``-(T_r + L_n)/K_0`` with ``K_0 = 1/(2 L_n K_n)`` (eq. 36) or ``0.6/(L_n K_n)`` (eq. 51)."""
    gain, ln, tr = 0.6, 2.5, 1.8
    plant, controller = Plant([gain], [1.0, 0.0], ln), MSP(gain, ln, tr, extension)
    error, dt = _load_error(plant, controller, horizon=80.0)
    k0 = (0.6 if extension else 0.5) / (ln * gain)
    assert np.trapezoid(error, dx=dt) == pytest.approx(-(tr + ln) / k0, rel=1e-6)
    result = iae(plant, controller)
    assert result.setpoint == pytest.approx(ln + tr, rel=2e-3)
    assert result.load >= (tr + ln) / k0 * (1 - 2 * SETTLED_SHARE)  # IAE >= |int e|, up to the truncation


def test_loops_with_a_steady_offset_have_infinite_iae():
    """Without integral action the error keeps an offset: P control of a lag (both inputs) and PD
    control of an integrating plant (load only; the plant's integrator removes the set-point offset)."""
    lag = iae(Plant.from_time_constants(1.0, [1.0], 0.5), PID(0.5, None))
    assert math.isinf(lag.load) and math.isinf(lag.setpoint)
    integrating = iae(Plant([1.0], [1.0, 0.0], 1.0), PID(0.3, None, 0.5, 10.0))
    assert math.isinf(integrating.load)
    assert math.isfinite(integrating.setpoint)
    assert integrating.setpoint >= (1 / 0.3) * (1 - 1e-6)  # >= |int e dt| = 1/(kp K_v)


def test_slow_plant_is_not_reported_as_diverged():
    """Time-scale invariance, concretely: the same loop with every time x100 (velocity gain /100) must
    have 100 times the IAE (a regression test: divergence was once judged on raw state coordinates,
    which a slow plant's realization makes ~1e8 times its output)."""
    fast = iae(Plant.from_time_constants(1.0, [1.0] * 3, 1.0, integrating=True), PID(0.1, 30.0))
    slow = iae(Plant.from_time_constants(0.01, [100.0] * 3, 100.0, integrating=True), PID(0.1, 3000.0))
    assert math.isfinite(fast.load) and math.isfinite(fast.setpoint)
    assert slow.load == pytest.approx(100 * fast.load, rel=1e-6)
    assert slow.setpoint == pytest.approx(100 * fast.setpoint, rel=1e-6)


def test_batched_iae_equals_single():
    plants = [Plant.from_time_constants(1.0, [1.0], 0.5), Plant.from_time_constants(0.5, [2.0, 1.0], 3.0), Plant([1.0], [1.0, 0.0], 1.0)]
    controllers = [PID(1.0, 1.0, 0.1, 10.0), FPPI(0.5, 2.4, 3.6, 2.0, 2.0), MSP(1.0, 1.0, 1.0)]
    assert iae_batch(plants, controllers) == [iae(p, c) for p, c in zip(plants, controllers)]


# ----------------------------------------------------------------------------- fine step
FINE_STEP_ROWS = {
    # name: (plant, controller, horizon in T_ar, RK4 step h)
    "pid-fopdt": (Plant.from_time_constants(1.0, [1.0], 0.5), PID(1.0, 1.0, 0.1, 10.0), 25.0, 0.005),
    "pid-lag-chain": (Plant.from_time_constants(1.0, [0.5] * 4, 0.6), PID(0.8, 1.8, 0.5, 8.0), 25.0, 0.005),
    "fppi-model-mismatch": (Plant.from_time_constants(1.0, [1.0, 0.5], 0.4), FPPI(1.0, 1.2, 0.7, 1.0, 1.0), 25.0, 0.005),
    "msp-integrating": (Plant.from_time_constants(1.0, [0.5], 1.0, integrating=True), MSP(1.0, 1.5, 1.5), 40.0, 0.005),
    "msp-extension-dead-time-error": (
        Plant.from_time_constants(2.0, [0.3, 0.3], 1.2, integrating=True), MSP(2.0, 1.5, 2.0, True), 40.0, 0.005,
    ),
}
IAE_RTOL = 5e-3
"""The IAE under test against the reference: 0.5% (measured <= 1.3e-4 at the scoring step T_ar/50)."""


@pytest.mark.parametrize("name", FINE_STEP_ROWS)
def test_iae_agrees_with_independent_fine_step_simulation(name):
    """RK4 at ``h <= T_ar/300`` on the hand-written loop equations vs. the scored IAE (``iae``, its own
    horizon and settling rule) and the IAE of ``closed_loop_response`` over the reference's horizon.
    The reference's own error (``O(h^2)`` trapezoidal IAE: ``4/3`` of the change when ``h`` is halved;
    measured <= 1e-5 relative) must be far below the tolerance for the comparison to mean anything."""
    plant, controller, horizon, h = FINE_STEP_ROWS[name]
    t_end = horizon * plant.step_time_scale()
    run = fine_step_response(plant, controller, t_end, h)
    reference = absolute_area(run.error, h)  # [load, set point]
    tail = absolute_area(run.error[-run.timepts.size // 10 :], h)
    assert np.all(tail < 1e-6 * reference), "reference horizon too short"
    halved = absolute_area(fine_step_response(plant, controller, t_end, h / 2).error, h / 2)
    assert np.all(4 / 3 * np.abs(reference - halved) < 0.01 * IAE_RTOL * reference), "reference not fine enough"

    scored = iae(plant, controller)
    np.testing.assert_allclose([scored.load, scored.setpoint], reference, rtol=IAE_RTOL)

    dt = simulation_step(plant, controller)
    steps = int(t_end / dt) + 1
    for column, inputs in enumerate(({"load": 1.0}, {"setpoint": 1.0})):
        response = closed_loop_response(plant, controller, steps, dt, **inputs)
        assert integrated_absolute_error(response.error, dt) == pytest.approx(reference[column], rel=IAE_RTOL)


# ----------------------------------------------------------------------------- the quadrature
def _exact_piecewise_linear_iae(values: np.ndarray, dt: float) -> float:
    """Insert every zero crossing as a breakpoint; between breakpoints ``|e|`` is linear."""
    t = np.arange(values.size) * dt
    times, points = [t[0]], [values[0]]
    for k in range(values.size - 1):
        a, b = values[k], values[k + 1]
        if a * b < 0:
            times.append(t[k] + dt * a / (a - b))
            points.append(0.0)
        times.append(t[k + 1])
        points.append(b)
    return float(np.trapezoid(np.abs(points), times))


@pytest.mark.parametrize(
    "values, dt, expected",
    [
        ([1.0, -1.0], 1.0, 0.5),  # two triangles of area 1/4
        ([0.0, 1.0, 0.0, -1.0, 0.0], 0.5, 1.0),
        ([2.0, 2.0, 2.0], 0.25, 1.0),
        ([3.0, -1.0], 2.0, 2.5),  # zero at t = 1.5: 3*1.5/2 + 1*0.5/2
        ([0.0, 0.0], 1.0, 0.0),
        ([-1.0, 0.0, 1.0], 1.0, 1.0),
    ],
)
def test_integrated_absolute_error_reference_rows(values, dt, expected):
    assert integrated_absolute_error(np.array(values), dt) == pytest.approx(expected, abs=1e-15)


@pytest.mark.parametrize("seed", range(5))
def test_integrated_absolute_error_is_exact_for_piecewise_linear_signals(seed):
    rng = np.random.default_rng(seed)
    values = rng.normal(size=500)
    values[rng.integers(0, 500, size=20)] = 0.0  # exact zeros at samples too
    dt = rng.uniform(0.01, 2.0)
    assert integrated_absolute_error(values, dt) == pytest.approx(_exact_piecewise_linear_iae(values, dt), rel=1e-12)


def test_analysis_of_an_unstable_loop_is_a_result():
    result = analyze(Plant.from_time_constants(1.0, [1.0], 0.5), PID(kp=8.0, ti=1.0)).to_dict()
    assert result["stable"] is False
    assert result["iae_load"] is None and result["iae_setpoint"] is None


def test_the_initial_horizon_changes_the_iae_only_within_the_settling_tolerance(monkeypatch):
    """Starting the doubling at 10 residence times (``HORIZON``) instead of 40 stops some runs
    earlier, by the same settling test: the IAE moves by about ``SETTLED_SHARE`` at most."""
    import envs.analysis.performance as performance
    from baselines.oracle import PARAMETER_RANGES, design, relative_scale
    from envs.systems.families import sample_plants
    from envs.identification.procedure import identify

    loops = []
    for family in ("fopdt", "sopdt", "lag-chain", "integrating"):
        for i, plant in enumerate(sample_plants(family, 3, 11)):
            found = identify(plant, np.random.default_rng(i))
            for structure in ("msp",) if plant.integrating else ("pid", "fppi"):
                model = {"pid": found.sopdt, "fppi": found.fopdt, "msp": found.integrating_model}[structure]
                low, high = PARAMETER_RANGES[structure]
                for relative in np.geomspace(low, high, 4):
                    loops.append((plant, design(structure, model, relative * relative_scale(structure, model))))
    short = [iae(p, c) for p, c in loops]
    monkeypatch.setattr(performance, "HORIZON", 40.0)
    long = [iae(p, c) for p, c in loops]
    compared = 0
    for a, b in zip(short, long):
        assert a.horizon <= b.horizon
        for x, y in ((a.load, b.load), (a.setpoint, b.setpoint)):
            if math.isfinite(y) and b.settled:
                assert x == pytest.approx(y, rel=2 * performance.SETTLED_SHARE)
                compared += 1
    assert compared > 50 and any(a.horizon < b.horizon for a, b in zip(short, long))
