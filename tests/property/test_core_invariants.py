"""Invariants of the physics core, over random plants and controllers (hypothesis).

* Time-scale invariance: ``P(s) -> P(c s)``, ``C(s) -> C(c s)`` (every time constant, dead time and
  controller time times ``c``; a velocity gain divided by ``c``) scales the IAE by ``c`` and every
  frequency by ``1/c``, the delay margin by ``c``, and leaves ``Ms``, ``Mt``, gain and phase margins
  unchanged.
* Gain invariance: plant gain times ``g`` and controller gain divided by ``g`` leaves the loop, hence
  every robustness figure and the set-point IAE, unchanged; the load IAE (a unit load at the plant
  input) scales by ``|g|``.
* Integral action removes the offset: after a load step the error of a stable loop goes to zero.
* The output lags a staircase input by exactly the dead time.

The scoring pipeline samples in units of the plant's ``T_ar``, so the scaled runs are the same
computation up to rounding; the tolerances (1e-7) allow for that and for the root finders.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from envs.analysis.loop_analysis import plant_margins
from envs.systems.controllers import FPPI, MSP, PID, SeriesPID
from envs.simulation.loops import closed_loop_response, simulation_step
from envs.analysis.performance import iae
from envs.systems.plants import Plant
from envs.simulation.open_loop import open_loop_response

SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow], derandomize=True)

log_uniform = lambda lo, hi: st.floats(math.log(lo), math.log(hi)).map(math.exp)  # noqa: E731


@st.composite
def plants(draw, integrating: bool | None = None) -> Plant:
    """Stable or integrating plants shaped like the families: FOPDT, SOPDT, lag chains, NMP."""
    shape = draw(st.sampled_from(["fopdt", "sopdt", "lag-chain", "nmp"]))
    scale = draw(log_uniform(0.1, 10.0))
    if shape == "fopdt":
        lags = [scale]
    elif shape == "sopdt":
        lags = [scale, scale * draw(st.floats(0.05, 1.0))]
    elif shape == "lag-chain":
        ratio = draw(st.floats(0.3, 1.0))
        lags = [scale * ratio**k for k in range(draw(st.integers(2, 5)))]
    else:
        lags = [scale] * 3
    zeros = [-scale * draw(st.floats(0.1, 1.0))] if shape == "nmp" else []
    delay = scale * draw(st.floats(0.05, 3.0))
    gain = draw(log_uniform(0.1, 10.0)) * draw(st.sampled_from([1.0, -1.0]))
    integrating = draw(st.booleans()) if integrating is None else integrating
    return Plant.from_time_constants(gain, lags, delay, zero_time_constants=zeros, integrating=integrating)


@st.composite
def loops(draw, integrating: bool | None = None) -> tuple[Plant, object]:
    """A plant and a controller with integral action, designed from the plant's moments with a
    random aggressiveness (stability is not guaranteed; the tests assume it)."""
    plant = draw(plants(integrating=integrating))
    t_ar, gain = plant.residence_time, plant.gain
    if plant.integrating:  # gain is the velocity gain K_v; T_ar is L_n of the two-parameter model
        if draw(st.booleans()):
            return plant, MSP(gain, t_ar, t_ar * draw(st.floats(0.5, 3.0)), extension=draw(st.booleans()))
        return plant, PID(kp=draw(st.floats(0.1, 0.3)) / (gain * t_ar), ti=t_ar * draw(st.floats(4.0, 10.0)))
    kind = draw(st.sampled_from(["pid", "series-pid", "fppi"]))
    kappa = draw(st.floats(0.1, 0.6))
    if kind == "pid":
        td = t_ar * draw(st.sampled_from([0.0, 0.1, 0.25]))
        return plant, PID(kp=kappa / gain, ti=t_ar * draw(st.floats(0.3, 1.0)), td=td, n=10.0)
    if kind == "series-pid":
        return plant, SeriesPID(kp=kappa / gain, ti=t_ar * draw(st.floats(0.3, 1.0)), td=t_ar * 0.1, n=10.0)
    split = draw(st.floats(0.2, 0.8))
    tr = t_ar * draw(st.floats(0.5, 2.0))
    return plant, FPPI(gain, split * t_ar, (1 - split) * t_ar, tr, tr * draw(st.sampled_from([0.0, 1.0])))


def time_scaled(plant: Plant, controller, c: float):
    """``P(c s)`` and ``C(c s)``: coefficient of ``s^k`` times ``c^k``, times ``c``; velocity gains ``/c``."""
    def substitute(coefficients):
        k = np.arange(len(coefficients))[::-1]
        return tuple(np.asarray(coefficients) * c**k)

    scaled_plant = Plant(substitute(plant.num), substitute(plant.den), plant.dead_time * c)
    if isinstance(controller, (PID, SeriesPID)):
        ti = None if controller.ti is None else controller.ti * c
        scaled = type(controller)(controller.kp, ti, controller.td * c, controller.n)
    elif isinstance(controller, FPPI):
        scaled = FPPI(controller.gain, controller.time_constant * c, controller.dead_time * c, controller.tr * c, controller.tf * c)
    else:
        scaled = MSP(controller.gain / c, controller.dead_time * c, controller.tr * c, controller.extension)
    return scaled_plant, scaled


def gain_scaled(plant: Plant, controller, g: float):
    scaled_plant = Plant(tuple(np.asarray(plant.num) * g), plant.den, plant.dead_time)
    if isinstance(controller, (PID, SeriesPID)):
        scaled = type(controller)(controller.kp / g, controller.ti, controller.td, controller.n)
    elif isinstance(controller, FPPI):
        scaled = FPPI(controller.gain * g, controller.time_constant, controller.dead_time, controller.tr, controller.tf)
    else:
        scaled = MSP(controller.gain * g, controller.dead_time, controller.tr, controller.extension)
    return scaled_plant, scaled


ROBUSTNESS_INVARIANT = ("ms", "mt", "gain_margin", "phase_margin_deg")
FREQUENCIES = ("gain_crossover_frequency", "phase_crossover_frequency", "delay_margin_frequency")
# The frequency of a flat maximum is ill-conditioned (an error eps in |S| moves its argmax by
# ~sqrt(eps)); a wider run found 2.2e-7 for a loop with Ms = 1.037.
PEAK_FREQUENCY_RTOL = 1e-5


def _same(a: float, b: float, rel: float = 1e-7) -> bool:
    if math.isinf(a) or math.isnan(a):
        return (math.isinf(b) and a == b) or (math.isnan(a) and math.isnan(b))
    return math.isclose(a, b, rel_tol=rel, abs_tol=1e-12)


@settings(max_examples=12, **SETTINGS)
@given(loop=loops(), c=log_uniform(1e-2, 1e2))
def test_time_scale_invariance(loop, c):
    plant, controller = loop
    base = plant_margins(plant, controller)
    assume(base.stable and base.ms < 5)
    scaled_plant, scaled_controller = time_scaled(plant, controller, c)
    scaled = plant_margins(scaled_plant, scaled_controller)
    assert scaled.stable
    for name in ROBUSTNESS_INVARIANT:
        assert _same(getattr(scaled, name), getattr(base, name)), name
    for name in FREQUENCIES:
        assert _same(getattr(scaled, name) * c, getattr(base, name)), name
    assert _same(scaled.ms_frequency * c, base.ms_frequency, rel=PEAK_FREQUENCY_RTOL)
    assert _same(scaled.delay_margin, base.delay_margin * c)
    performance, scaled_performance = iae(plant, controller), iae(scaled_plant, scaled_controller)
    assert _same(scaled_performance.load, performance.load * c, rel=1e-6)
    assert _same(scaled_performance.setpoint, performance.setpoint * c, rel=1e-6)


def test_time_scale_invariance_found_by_hypothesis():
    """The shrunk counterexample of a wider (150-example) run of the property above: PI on
    ``(1 - s) e^{-s}/(s (s+1)^3)``, times scaled by ``c = e^4``; ``plant_margins`` agree, ``iae``
    returns ``inf`` for the scaled loop (its plant states exceed the 1e8 divergence limit)."""
    plant = Plant((-1.0, 1.0), (1.0, 3.0, 3.0, 1.0, 0.0), 1.0)
    controller = PID(kp=0.05, ti=20.0)
    c = math.exp(4.0)
    scaled_plant, scaled_controller = time_scaled(plant, controller, c)
    assert plant_margins(scaled_plant, scaled_controller).stable
    base, scaled = iae(plant, controller), iae(scaled_plant, scaled_controller)
    assert _same(scaled.load, base.load * c, rel=1e-6)


@settings(max_examples=12, **SETTINGS)
@given(loop=loops(), g=log_uniform(1e-2, 1e2), sign=st.sampled_from([1.0, -1.0]))
def test_gain_invariance(loop, g, sign):
    plant, controller = loop
    g *= sign
    base = plant_margins(plant, controller)
    assume(base.stable and base.ms < 5)
    scaled_plant, scaled_controller = gain_scaled(plant, controller, g)
    scaled = plant_margins(scaled_plant, scaled_controller)
    assert scaled.stable
    for name in ROBUSTNESS_INVARIANT + FREQUENCIES + ("delay_margin",):
        assert _same(getattr(scaled, name), getattr(base, name)), name
    assert _same(scaled.ms_frequency, base.ms_frequency, rel=PEAK_FREQUENCY_RTOL)
    performance, scaled_performance = iae(plant, controller), iae(scaled_plant, scaled_controller)
    assert _same(scaled_performance.setpoint, performance.setpoint, rel=1e-6)
    assert _same(scaled_performance.load, performance.load * abs(g), rel=1e-6)


@settings(max_examples=20, **SETTINGS)
@given(loop=loops())
def test_integral_action_removes_the_offset(loop):
    """A load step at the plant input: the error of a stable loop with integral action returns to 0
    (to 1e-6 of its peak after 600 time scales; the designs drawn settle well within that)."""
    plant, controller = loop
    margins = plant_margins(plant, controller)
    assume(margins.stable and margins.ms < 4)
    dt = simulation_step(plant, controller)
    steps = int(600 * plant.step_time_scale() / dt)
    error = closed_loop_response(plant, controller, steps, dt, load=1.0).error
    assert np.all(np.isfinite(error))
    assert abs(error[-1]) <= 1e-6 * np.max(np.abs(error))


@pytest.mark.parametrize("kp", [0.2, 1.0, 3.0])
def test_proportional_control_keeps_the_textbook_offset(kp):
    """The contrast: P control of ``K e^{-Ls}/(Ts+1)`` leaves ``e = -K/(1 + K kp)`` after a unit load."""
    plant = Plant.from_time_constants(1.5, [1.0], 0.3)
    dt = simulation_step(plant, PID(kp, None))
    error = closed_loop_response(plant, PID(kp, None), int(200 / dt), dt, load=1.0).error
    assert error[-1] == pytest.approx(-1.5 / (1 + 1.5 * kp), rel=1e-6)


@settings(max_examples=40, **SETTINGS)
@given(
    plant=plants(),
    fraction=st.floats(0.05, 0.95),
    whole=st.integers(0, 30),
    seed=st.integers(0, 2**16),
)
def test_output_lags_input_by_exactly_the_dead_time(plant, fraction, whole, seed):
    """With ``L = (m + f) dt`` the output of a staircase input that starts at ``t = 0`` is exactly 0
    before ``L`` and non-zero at the first sample after it; a whole-sample delay is an exact shift."""
    dt = plant.step_time_scale() / 20
    rng = np.random.default_rng(seed)
    u = rng.uniform(0.5, 1.5, size=whole + 40)  # never zero, so the response cannot vanish by chance
    ss = plant.state_space()
    delay = (whole + fraction) * dt
    y = open_loop_response(ss, delay, u, dt)
    t = np.arange(u.size) * dt
    assert np.all(y[t < delay] == 0.0)
    assert y[whole + 1] != 0.0  # t = (m + 1) dt, the first sample after L
    free = open_loop_response(ss, 0.0, u, dt)
    shifted = open_loop_response(ss, whole * dt, u, dt)
    np.testing.assert_allclose(shifted[whole:], free[: u.size - whole], rtol=0, atol=1e-12 * np.max(np.abs(free)))


WIDE_GAINS = [sign * 10.0**e for e in (-12, -9, -6, -3, 0, 3, 6, 9, 12) for sign in (1.0, -1.0)]
NORMALIZED_LOOPS = {
    "pid-fopdt": (Plant((1.0,), (10.0, 1.0), 5.0), PID(kp=1.2, ti=9.0, td=1.5, n=10.0)),
    "fppi-sopdt": (Plant((1.0,), (2.0, 3.0, 1.0), 1.0), FPPI(1.0, 3.0, 1.0, 2.0, 2.0)),
    "msp-integrating": (Plant((1.0,), (1.0, 1.0, 0.0), 2.0), MSP(1.0, 3.0, 3.0, extension=False)),
}


@pytest.mark.parametrize("g", WIDE_GAINS)
@pytest.mark.parametrize("name", list(NORMALIZED_LOOPS))
def test_cost_is_gain_invariant_over_the_documented_range(name, g):
    """The cost of one normalized loop (plant gain ``g``, controller gain ``1/g``) is the
    same over the whole documented range ``|K|`` in [1e-12, 1e12] (``envs.systems.plants.GAIN_RANGE``); a fixed
    divergence limit on the loop's states would cap it at 20 from ``K = 1e8`` on.
    Tolerance: the IAE's own rounding across gains, as in :func:`test_gain_invariance` (1e-6
    relative; the differences measured here are below 1e-12).
    At ``|K| = 1e-12`` the difference is 1e-5 to 2e-4 (measured), not rounding: something in the IAE run
    is absolute (not yet found); there the bound is the IAE's own error, 6e-4 (the
    bench's largest error against the fine-step reference, docs/performance.md)."""
    from envs.analysis.scoring import Constraints, score

    plant, controller = NORMALIZED_LOOPS[name]
    constraints = Constraints(max_sensitivity=None) if isinstance(controller, MSP) else Constraints()  # its Ms is 2.2
    base = score(plant, controller, constraints=constraints)
    scaled = score(*gain_scaled(plant, controller, g), constraints=constraints)
    assert base.feasible and scaled.feasible
    rel = 6e-4 if abs(g) < 1e-10 else 1e-6
    assert _same(scaled.cost, base.cost, rel=rel)
    assert _same(scaled.iae_setpoint, base.iae_setpoint, rel=rel)
    assert _same(scaled.iae_load, base.iae_load * abs(g), rel=rel)
