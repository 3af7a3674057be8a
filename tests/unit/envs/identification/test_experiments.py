"""Identification experiments (envs.identification.experiments) on true plants, noise-free and noisy.

Noise-free results are checked against exact values (the plant's Taylor coefficients, analytic
step, ramp and relay responses); Ingimundarson's Table 1 (section 4.4) is compared with generous
tolerances, the deviations being explained where they are large.
"""

import math

import numpy as np
import pytest
import scipy.optimize

from envs.systems.controllers import PID
from envs.identification.experiments import (
    COMMISSIONING_MAX_SENSITIVITY,
    closed_loop_step,
    commissioning_pi,
    max_sensitivity,
    open_loop_pulse,
    open_loop_ramp,
    open_loop_step,
    relay_feedback,
    steady_state_index,
)
from envs.identification.experiment_base import measurement_noise
from envs.identification.models import FOPDTModel, SOPDTModel
from envs.simulation.loops import loop_response
from envs.systems.plants import Plant

lags = Plant.from_time_constants


def rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def exact_moments(plant: Plant) -> tuple[float, float]:
    """``(T_ar, T_a)`` of the plant (Gorez-Klan eq. 2-5, 2-6), ``T_a`` clipped at 0."""
    p1, p2 = plant.taylor_coefficients()
    return -p1, math.sqrt(max(2 * p2 - p1 * p1, 0.0))


def shaped(num, den, gain: float, delay: float, integrating: bool) -> Plant:
    """``gain num/den e^{-delay s}`` (times ``1/s`` if integrating); ``num/den`` has unit gain."""
    den = np.polymul(den, [1.0, 0.0]) if integrating else np.asarray(den, float)
    return Plant(num=tuple(gain * np.asarray(num, float)), den=tuple(den), dead_time=delay)


# --------------------------------------------------------------------------- commissioning PI
def shapes():
    """Unit-gain shapes of the plant families (envs.systems.shapes' table) and harsher ones."""
    out = {"lag": ([1], [1, 1])}
    out |= {f"two-lags-{r}": ([1], np.polymul([1, 1], [r, 1])) for r in (0.05, 0.5, 1.0)}
    out |= {f"underdamped-{z}": ([1], [1, 2 * z, 1]) for z in (0.2, 0.4, 0.7, 1.0)}
    out |= {f"lag-{n}": ([1], np.poly(-np.ones(n)).tolist()) for n in (3, 6, 10)}
    out |= {f"geometric-{a}": ([1], np.polymul(np.polymul([1, 1], [a, 1]), np.polymul([a * a, 1], [a**3, 1]))) for a in (0.2, 0.9)}
    out |= {f"nmp-{a}-{m}": ([-a, 1], np.poly(-np.ones(m)).tolist()) for a in (0.5, 2.0) for m in (3, 5)}
    out |= {f"resonant-{w}-{z}": ([1], np.polymul([1, 1], [1 / w**2, 2 * z / w, 1])) for w in (1.5, 5.0) for z in (0.2, 0.7)}
    out |= {f"parallel-{c}-{t}": ([(1 - c) * t + c, 1], np.polymul([1, 1], [t, 1])) for c in (0.2, 0.8) for t in (3.0, 30.0)}
    return out


def family_plants(integrating: bool, fractions: tuple[float, ...]) -> list:
    """Every shape with dead times ``fraction * 2`` (the shapes' time scale is about 1 to 10)."""
    plants = []
    for name, (num, den) in shapes().items():
        for fraction in fractions:
            delay = fraction * 2.0
            gain = -3.0 if name == "lag-3" else 1.0
            kind = "int-" if integrating else ""
            plants.append(pytest.param(shaped(num, den, gain, delay, integrating), id=f"{kind}{name}-L{delay:g}"))
    return plants


def fopdt_plants() -> list:
    return [pytest.param(lags(1.0, [1 - tau], tau), id=f"fopdt-tau{tau}") for tau in np.round(np.linspace(0.05, 0.95, 7), 2)]


def nyquist_stable(plant: Plant, controller) -> bool:
    """Closed-loop stability of ``L = P C`` with one pole of ``L`` at the origin and none in the
    right half plane: stable iff ``arg(1 + L)`` rises by ``pi/2`` from ``omega = 0+`` to infinity
    (Nyquist contour indented to the right of the origin)."""
    omega = np.logspace(-6, 4, 60000) / plant.step_time_scale()
    phase = np.unwrap(np.angle(1.0 + loop_response(plant, controller, omega)))
    return abs(phase[-1] - phase[0] - math.pi / 2) < 1e-2


def dense_max_sensitivity(plant: Plant, controller) -> float:
    """On a grid independent of (and 6 times finer than) the one the design used."""
    omega = np.logspace(-5, 3, 20000) / plant.step_time_scale()
    return float(np.max(1.0 / np.abs(1.0 + loop_response(plant, controller, omega))))


def check_commissioning_pi(plant: Plant) -> None:
    controller = commissioning_pi(plant)
    assert dense_max_sensitivity(plant, controller) < 1.6
    assert max_sensitivity(plant, controller) <= COMMISSIONING_MAX_SENSITIVITY + 1e-12
    assert nyquist_stable(plant, controller)
    assert (controller.ti is None) == plant.integrating
    assert controller.kp * plant.gain > 0


@pytest.mark.parametrize("plant", fopdt_plants() + family_plants(False, (0.3,)) + family_plants(True, (0.5,)))
def test_commissioning_pi_is_stable_with_large_margins(plant):
    check_commissioning_pi(plant)


@pytest.mark.slow
@pytest.mark.parametrize("plant", family_plants(False, (0.0, 0.05, 0.9)) + family_plants(True, (0.0, 0.05, 0.9)))
def test_commissioning_pi_is_stable_with_large_margins_everywhere(plant):
    check_commissioning_pi(plant)


def test_commissioning_pi_rule_on_a_fopdt():
    """Lambda rule with lambda = T_ar: T_i = T_a, K_p = T_i/(K (T_ar + D_a)); Ms 1.23, no detuning."""
    plant = lags(2.0, [0.7], 0.3)
    controller = commissioning_pi(plant)
    assert controller.ti == pytest.approx(0.7)
    assert controller.kp == pytest.approx(0.7 / (2.0 * 1.3))


def test_commissioning_pi_refuses_bad_target():
    with pytest.raises(ValueError, match="max_sensitivity_target must be > 1"):
        commissioning_pi(lags(1.0, [1.0], 1.0), 1.0)


# --------------------------------------------------------------------------- steady state
def test_steady_state_index_noise_free_and_noisy():
    t = np.arange(4000) * 0.01
    y = 1 - np.exp(-t)
    k = steady_state_index(t, y, 100, target=1.0)
    assert 1e-5 * 0.5 < np.exp(-t[k]) < 1e-5 * 1.5  # the tolerance floor, 1e-5 of the change
    noisy = y + 0.01 * rng().standard_normal(t.size)
    k_noisy = steady_state_index(t, noisy, 100, target=1.0)
    assert 2.0 < t[k_noisy] < t[k]  # within a few standard errors of 1 (0.003), earlier
    assert steady_state_index(t, np.zeros(t.size), 100) is None  # never started
    assert steady_state_index(t, y, 100, start=3000) == 3000


# --------------------------------------------------------------------------- experiment 1
STABLE_PLANTS = [
    pytest.param(lags(1.0, [10.0, 2.0], 5.0), id="ingimundarson-P1"),
    pytest.param(lags(2.0, [0.95], 0.05), id="fopdt-tau0.05"),
    pytest.param(lags(-0.5, [0.3], 0.7), id="fopdt-tau0.7-negative"),
    pytest.param(lags(1.0, [0.05], 0.95), id="fopdt-tau0.95"),
    pytest.param(lags(1.0, [1.0] * 10), id="lag-10"),
    pytest.param(lags(3.0, [0.4**k for k in range(4)], 0.2), id="geometric"),
    pytest.param(lags(1.0, [1.0] * 3, 5.0, zero_time_constants=[-2.0]), id="ingimundarson-P4"),
    pytest.param(lags(1e3, [200.0, 50.0], 100.0), id="slow-large-gain"),
]


@pytest.mark.parametrize("plant", STABLE_PLANTS)
def test_closed_loop_step_noise_free_is_exact(plant):
    result = closed_loop_step(plant, rng(), amplitude=2.0)
    residence_time, apparent = exact_moments(plant)
    assert result.settled and not result.aborted
    assert result.gain == pytest.approx(plant.gain, rel=1e-4)
    assert result.residence_time == pytest.approx(residence_time, rel=1e-4)
    assert result.apparent_time_constant == pytest.approx(min(apparent, residence_time), abs=0.01 * residence_time)
    assert result.normalized_dead_time == pytest.approx(1 - result.apparent_time_constant / result.residence_time)
    assert result.sopdt == SOPDTModel(result.gain, result.sopdt.time_constants, result.sopdt.dead_time)
    assert result.sopdt.residence_time == pytest.approx(result.residence_time)
    assert result.fopdt.time_constant == pytest.approx(result.apparent_time_constant)
    assert result.integrating_model is None
    assert result.duration == pytest.approx(result.timepts[-1])
    assert result.relative_duration == pytest.approx(result.duration / residence_time)
    assert 5 < result.relative_duration < 30
    assert np.max(np.abs(result.output - result.true_output)) == 0.0


INTEGRATING_PLANTS = [
    pytest.param(Plant(num=[2.0], den=[1.0, 0.0], dead_time=3.0), id="pure-integrator"),
    pytest.param(lags(1.0, [1.0], 5.0, integrating=True), id="ingimundarson-int-P1"),
    pytest.param(lags(-0.1, [1.0] * 3, 5.0, integrating=True, zero_time_constants=[-1.0]), id="nmp-negative"),
]


@pytest.mark.parametrize("plant", INTEGRATING_PLANTS)
def test_closed_loop_step_integrating_plant(plant):
    result = closed_loop_step(plant, rng())
    assert result.settled
    assert result.gain == pytest.approx(plant.gain, rel=1e-4)
    assert result.residence_time == pytest.approx(plant.residence_time, rel=1e-3)
    assert result.integrating_model.dead_time == result.residence_time
    assert result.sopdt is None and result.fopdt is None
    assert result.controller.ti is None  # proportional only: the plant integrates


def test_closed_loop_step_noise_is_reproducible_and_roughly_unbiased():
    plant = lags(1.0, [10.0, 2.0], 5.0)
    first = closed_loop_step(plant, rng(7), noise_std=0.02)
    again = closed_loop_step(plant, rng(7), noise_std=0.02)
    assert np.array_equal(first.output, again.output) and first.residence_time == again.residence_time
    runs = [closed_loop_step(plant, rng(seed), noise_std=0.02) for seed in range(12)]
    gains = np.array([r.gain for r in runs])
    times = np.array([r.residence_time for r in runs])
    assert np.std(times) > 0.01
    # Stopping as soon as the tail is lost in the noise leaves a small positive bias (about one
    # standard deviation of one run), well under 1%.
    assert abs(np.mean(gains) - 1.0) < 0.005
    assert abs(np.mean(times) - 17.0) < 0.01 * 17.0
    assert all(r.relative_duration < 11.0 for r in runs)  # noise ends the experiment earlier


def test_closed_loop_step_same_noise_whatever_its_level():
    plant = lags(1.0, [1.0], 1.0)
    low = closed_loop_step(plant, rng(3), noise_std=1e-3, max_duration=20)
    high = closed_loop_step(plant, rng(3), noise_std=2e-3, max_duration=20)
    k = min(low.timepts.size, high.timepts.size)
    assert np.allclose(2 * (low.output - low.true_output)[:k], (high.output - high.true_output)[:k])


def test_noise_is_drawn_as_needed_and_the_same_in_parts():
    """The noise of an experiment comes from a child stream, drawn only for the samples simulated;
    in parts or at once, the samples are the same."""
    parts = measurement_noise(rng(5), 0.5, 5000)
    whole = measurement_noise(rng(5), 0.5, 5000).first(5000)
    assert parts.first(0).size == 0 and parts.first(10).size == 10
    pieces = [parts.first(k)[start:] for start, k in ((0, 10), (10, 700), (700, 701), (701, 9999))]
    assert np.array_equal(np.concatenate(pieces), whole) and whole.size == 5000
    assert np.array_equal(measurement_noise(rng(5), 0.25, 5000).first(5000), 0.5 * whole)
    assert not np.any(measurement_noise(rng(5), 0.0, 5000).first(5000))


def test_experiment_noise_does_not_depend_on_earlier_experiments():
    """Each experiment takes the same from the episode's generator (its child's seed), whatever its
    noise level, duration or outcome: the next experiment's noise is the same."""
    plant = lags(1.0, [1.0], 1.0)
    durations, states, outputs = [], [], []
    for kwargs in ({"noise_std": 0.0}, {"noise_std": 0.05}, {"noise_std": 0.05, "max_duration": 3.0},
                   {"noise_std": 0.05, "amplitude": 20.0, "excursion_limit": 2.0}):
        generator = rng(9)
        durations.append(closed_loop_step(plant, generator, **kwargs).duration)
        states.append(generator.bit_generator.state)
        outputs.append(open_loop_step(plant, generator, 1.0, 2.0, 1.0, noise_std=0.05).output)
    assert len(set(durations)) == len(durations)
    assert all(state == states[0] for state in states)
    assert all(np.array_equal(output, outputs[0]) for output in outputs)


def test_closed_loop_step_excursion_aborts():
    plant = lags(1.0, [1.0], 1.0)
    result = closed_loop_step(plant, rng(), amplitude=1.0, excursion_limit=0.5)
    assert result.aborted and not result.settled
    assert abs(result.true_output[-1]) > 0.5 >= np.max(np.abs(result.true_output[:-1]))
    assert math.isnan(result.gain) and result.sopdt is None
    assert result.duration < 5.0


@pytest.mark.parametrize("noise_std", [0.0, 0.3])
def test_closed_loop_step_divergence_aborts_at_its_last_finite_sample(noise_std):
    """A too aggressive PI diverges: the run aborts at the sample whose next state reaches the limit
    of the inputs so far (its outputs are the last finite ones), whatever the cap beyond it."""
    plant = lags(2.0, [1.0], 1.0)
    runs = [
        closed_loop_step(plant, rng(4), noise_std=noise_std, controller=PID(kp=5.0, ti=0.5), max_duration=cap)
        for cap in (60.0, 150.0)
    ]
    for result in runs:
        assert result.aborted and not result.settled and result.duration > 0.0
        assert np.isfinite(result.true_output).all() and np.isfinite(result.control).all()
        assert np.max(np.abs(result.true_output)) > 1e3 and math.isnan(result.gain)
    assert runs[0].true_output.tobytes() == runs[1].true_output.tobytes()
    assert runs[0].output.tobytes() == runs[1].output.tobytes()


def test_closed_loop_step_with_a_given_controller():
    plant = lags(1.0, [1.0], 1.0)
    result = closed_loop_step(plant, rng(), controller=PID(kp=0.5, ti=1.5))
    assert result.controller == PID(kp=0.5, ti=1.5)
    assert result.residence_time == pytest.approx(2.0, rel=1e-4)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(amplitude=0.0), "amplitude must be non-zero, got 0.0"),
        (dict(noise_std=-1.0), "noise_std must be >= 0"),
        (dict(dt=0.0), "dt must be > 0"),
        (dict(max_duration=float("nan")), "max_duration must be finite"),
        (dict(controller=PID(kp=1.0, ti=None)), "controller must have integral action"),
    ],
)
def test_closed_loop_step_refuses_invalid_input(kwargs, message):
    with pytest.raises(ValueError, match=message):
        closed_loop_step(lags(1.0, [1.0], 1.0), rng(), **kwargs)


def test_experiments_refuse_invalid_plant_and_rng():
    with pytest.raises(ValueError, match="rng must be a numpy.random.Generator"):
        closed_loop_step(lags(1.0, [1.0], 1.0), 42)
    with pytest.raises(ValueError, match="plant must be an envs.systems.plants.Plant"):
        relay_feedback({"num": [1]}, rng(), 1.0)
    with pytest.raises(ValueError, match="plant must be self-regulating"):
        open_loop_step(lags(1.0, [1.0], 1.0, integrating=True), rng(), 1.0, 2.0, 1.0)
    with pytest.raises(ValueError, match="plant must be integrating"):
        open_loop_pulse(lags(1.0, [1.0], 1.0), rng(), 1.0, 1.0, 1.0, 1.0)


# --------------------------------------------------------------------------- experiment 2
def test_open_loop_step_on_a_true_fopdt_is_exact():
    plant = lags(-2.0, [3.0], 1.0)
    result = open_loop_step(plant, rng(), height=0.5, residence_time=4.0, gain=-2.0)
    assert result.settled
    assert result.raw_time_constant == pytest.approx(3.0, rel=1e-5)
    assert result.model == FOPDTModel(-2.0, result.time_constant, result.dead_time)
    assert result.dead_time == pytest.approx(1.0, abs=1e-4)
    assert result.final_output == pytest.approx(-1.0, rel=1e-4)
    assert result.mismatch_time == pytest.approx(0.0, abs=1e-4)
    two_point = result.two_point_model
    assert (two_point.gain, two_point.time_constant, two_point.dead_time) == pytest.approx((-2.0, 3.0, 1.0), rel=1e-4)
    tangent = result.tangent_model
    assert tangent.dead_time == pytest.approx(1.0, abs=1e-9)  # L = 50 dt is on the grid
    assert tangent.time_constant == pytest.approx(3.0, rel=0.01)


def test_open_loop_step_area_is_the_analytic_one():
    """Ingimundarson P1: A = int_0^17 y dt of 1/((10s+1)(2s+1)) e^{-5s}, eq. 11."""
    plant = lags(1.0, [10.0, 2.0], 5.0)
    result = open_loop_step(plant, rng(), 1.0, 17.0, 1.0)
    s = 12.0  # T_ar - L
    area = s - (100 * (1 - math.exp(-s / 10)) - 4 * (1 - math.exp(-s / 2))) / 8
    assert result.area == pytest.approx(area, rel=1e-5)  # trapezoid, dt = T_ar/200
    assert result.time_constant == pytest.approx(area * math.e, rel=1e-5)


# Ingimundarson Table 1 (section 4.4, P_i(s) e^{-5s}): T_n, L_n, T_f_bar as printed.
TABLE_1 = {
    1: (lags(1.0, [10.0, 2.0], 5.0), 10.4, 6.8, 0.27),
    2: (lags(1.0, [1.0] * 3, 5.0), 2.0, 6.2, 0.27),
    3: (lags(1.0, [1.0] * 5, 5.0, zero_time_constants=[-1.0]), 3.0, 9.1, 1.06),
    4: (lags(1.0, [1.0] * 3, 5.0, zero_time_constants=[-2.0]), 1.7, 8.4, 1.18),
    5: (Plant(num=[9.0], den=np.polymul([1, 1], [1, 2, 9]), dead_time=5.0), 0.8, 5.4, 0.17),
    6: (Plant(num=[0.55, 0.1], den=np.polymul([1, 1], [1, 0.1]), dead_time=5.0), 7.6, 2.6, 1.32),
    7: (Plant(num=[64.0], den=np.poly([-1, -2, -4, -8]), dead_time=5.0), 1.3, 5.7, 0.17),
}


@pytest.mark.parametrize("index", sorted(TABLE_1), ids=[f"P{i}" for i in sorted(TABLE_1)])
def test_ingimundarson_table_1(index):
    """Experiments 1 and 2 noise-free against Table 1.

    Our T_ar is exact (1e-4), while the printed T_n + L_n differ from the exact T_ar by up to 10%
    (P3: 12.1 against 11.0), so the paper's experiments were not noise-free or not long enough;
    the area over [0, T_ar] is sensitive to T_ar, hence T_n.  Computed (T_n, L_n, T_f_bar):
    P1 (10.23, 6.77, 0.23), P2 (1.83, 6.17, 0.24), P3 (2.18, 8.82, 0.35), P4 (1.15, 8.85, 1.07),
    P5 (0.81, 5.42, 0.12), P6 (7.85, 2.65, 1.34), P7 (1.19, 5.69, 0.10).  Tolerances: T_n + L_n
    within 10% of the printed sum, L_n within 0.6, T_f_bar within 0.1 except P3 (with the printed
    T_ar = 12.1 the area gives T_n = 4.2, L_n = 7.9, T_f_bar = 1.35: the printed row is between)
    and P4 within 0.15.
    """
    plant, t_n, l_n, t_f = TABLE_1[index]
    identified = closed_loop_step(plant, rng())
    assert identified.residence_time == pytest.approx(plant.residence_time, rel=1e-4)
    result = open_loop_step(plant, rng(), 1.0, identified.residence_time, identified.gain)
    assert result.time_constant + result.dead_time == pytest.approx(t_n + l_n, rel=0.1)
    assert result.dead_time == pytest.approx(l_n, abs=0.6)
    if index != 3:
        assert result.mismatch_time == pytest.approx(t_f, abs=0.15 if index == 4 else 0.1)


def test_open_loop_step_noise_biases_the_mismatch_area_only():
    plant = lags(1.0, [10.0, 2.0], 5.0)
    clean = open_loop_step(plant, rng(), 1.0, 17.0, 1.0)
    noisy = [open_loop_step(plant, rng(seed), 1.0, 17.0, 1.0, noise_std=0.01) for seed in range(8)]
    time_constants = np.array([r.time_constant for r in noisy])
    assert abs(np.mean(time_constants) - clean.time_constant) < 3 * np.std(time_constants) / math.sqrt(8) + 1e-3
    # int |f| dt picks up E|n| = 0.8 sigma per unit time: about 0.01 * 0.8 * 90 = 0.7 here.
    assert all(r.mismatch_time > clean.mismatch_time + 0.3 for r in noisy)
    assert np.mean([r.two_point_model.time_constant for r in noisy]) == pytest.approx(clean.two_point_model.time_constant, rel=0.05)


def test_open_loop_step_excursion_aborts_after_the_area():
    plant = lags(1.0, [1.0], 1.0)
    result = open_loop_step(plant, rng(), 1.0, 2.0, 1.0, excursion_limit=0.9)
    assert result.aborted and not result.settled
    assert result.model is not None and math.isnan(result.mismatch_time)
    early = open_loop_step(plant, rng(), 1.0, 2.0, 1.0, excursion_limit=0.1)
    assert early.aborted and early.model is None and early.duration < 2.0


# --------------------------------------------------------------------------- experiment 3
@pytest.mark.parametrize("plant", [lags(2.0, [3.0], 1.0), lags(1.0, [10.0, 2.0], 5.0)], ids=["fopdt", "P1"])
def test_open_loop_ramp(plant):
    residence_time = plant.residence_time
    result = open_loop_ramp(plant, rng(), rate=0.1, residence_time=residence_time, gain=plant.gain)
    assert result.duration == pytest.approx(residence_time)
    assert result.control == pytest.approx(0.1 * result.timepts)
    if plant.order == 1:  # eq. 12 is exact for a FOPDT
        assert result.time_constant == pytest.approx(3.0, rel=1e-5)
    else:  # the ramp response of P1, analytic: int of the step response
        s = result.timepts - 5.0
        sp = np.maximum(s, 0.0)
        ramp = sp - 12.0 + (100 * np.exp(-sp / 10) - 4 * np.exp(-sp / 2)) / 8
        assert np.allclose(result.true_output, 0.1 * np.where(s > 0, ramp, 0.0), atol=1e-9)


def test_open_loop_ramp_refuses_zero_rate():
    with pytest.raises(ValueError, match="rate must be non-zero"):
        open_loop_ramp(lags(1.0, [1.0], 1.0), rng(), 0.0, 2.0, 1.0)


# --------------------------------------------------------------------------- experiment 4
def test_open_loop_pulse_on_a_two_parameter_plant():
    plant = Plant(num=[0.5], den=[1.0, 0.0], dead_time=4.0)
    exact = open_loop_pulse(plant, rng(), height=2.0, duration=3.0, gain=0.5, dead_time=4.0)
    assert exact.settled
    assert exact.area == pytest.approx(0.0, abs=1e-9)
    assert exact.final_output == pytest.approx(0.5 * 2.0 * 3.0)
    assert (exact.pulse_model.gain, exact.pulse_model.dead_time) == pytest.approx((0.5, 4.0), rel=1e-6)
    wrong = open_loop_pulse(plant, rng(), height=2.0, duration=3.0, gain=0.5, dead_time=5.5)
    assert wrong.area == pytest.approx(0.5 * 1.5, rel=1e-4)  # K_n |delta L| (eq. 44, 46)


def test_open_loop_pulse_with_lags_bounds_delta_p0():
    """Eq. 46: A >= |delta P_0| = K_n (L + T - L_n) (eq. 44), with equality for an impulse-like
    pulse when the responses do not cross."""
    plant = lags(1.0, [1.0], 5.0, integrating=True)
    identified = closed_loop_step(plant, rng())
    result = open_loop_pulse(plant, rng(), 1.0, 1.0, identified.gain, identified.residence_time)
    assert result.area > 0.0
    delta_p0 = identified.gain * abs(6.0 - identified.residence_time)
    assert result.area >= delta_p0 - 1e-9
    assert result.pulse_model.dead_time == pytest.approx(6.0, rel=1e-4)


# --------------------------------------------------------------------------- experiment 5
def fopdt_relay_cycle(gain, time_constant, dead_time, amplitude):
    """Exact relay limit cycle of a FOPDT without hysteresis: half period
    ``L + T ln(2 - e^{-L/T})`` and amplitude ``K d (1 - e^{-L/T})``."""
    decay = math.exp(-dead_time / time_constant)
    return 2 * (dead_time + time_constant * math.log(2 - decay)), abs(gain) * amplitude * (1 - decay)


def phase_crossover(plant: Plant) -> tuple[float, float]:
    """Exact ``(T_u, K_u)``: the first frequency where the phase of ``sign(K) P`` is -pi."""
    omega = np.logspace(-3, 3, 20000) / plant.step_time_scale()
    phase = np.unwrap(np.angle(np.sign(plant.gain) * plant.frequency_response(omega)))
    k = int(np.flatnonzero(phase < -math.pi)[0])

    def excess(w: float) -> float:
        grid = np.append(omega[:k], w)
        return float(np.unwrap(np.angle(np.sign(plant.gain) * plant.frequency_response(grid)))[-1] + math.pi)

    w_u = scipy.optimize.brentq(excess, omega[k - 1], omega[k], xtol=1e-14)
    return 2 * math.pi / w_u, 1.0 / abs(plant.frequency_response(w_u))


def test_relay_on_an_integrator_with_dead_time_is_exact():
    """K e^{-Ls}/s: the period is 4 L (the true T_u); the output a triangle of amplitude K d L, so
    the describing function gives 4/(pi K L) while K_u = pi/(2 K L); the first harmonic is exact."""
    plant = Plant(num=[2.0], den=[1.0, 0.0], dead_time=3.0)
    result = relay_feedback(plant, rng(), amplitude=0.5)
    assert result.converged
    assert result.ultimate_period == pytest.approx(12.0, rel=1e-9)
    assert result.peak_amplitude == pytest.approx(2.0 * 0.5 * 3.0, rel=1e-9)
    assert result.ultimate_gain == pytest.approx(4 / (math.pi * 6.0), rel=1e-9)
    assert result.harmonic_ultimate_gain == pytest.approx(math.pi / (2 * 6.0), rel=1e-4)


@pytest.mark.parametrize("gain, time_constant, dead_time", [(1.0, 1.0, 1.0), (-2.0, 5.0, 0.37), (0.5, 0.2, 1.0)])
def test_relay_on_a_fopdt_matches_the_exact_limit_cycle(gain, time_constant, dead_time):
    """Switching instants interpolated linearly: the period is second-order accurate in dt."""
    plant = lags(gain, [time_constant], dead_time)
    period, amplitude = fopdt_relay_cycle(gain, time_constant, dead_time, 2.0)
    result = relay_feedback(plant, rng(), amplitude=2.0)
    finer = relay_feedback(plant, rng(), amplitude=2.0, dt=result.timepts[1] / 2)
    assert result.converged and finer.converged
    error, finer_error = abs(result.ultimate_period - period), abs(finer.ultimate_period - period)
    assert error < 1e-4 * period
    assert finer_error < error / 3 or finer_error < 1e-9 * period
    # The peak is a kink (the input switches there), so the largest sample misses it by O(dt).
    assert result.peak_amplitude == pytest.approx(amplitude, rel=1e-2)


@pytest.mark.parametrize(
    "plant, tolerance",
    [
        (lags(1.0, [0.9], 0.1), 0.02),  # lag-dominated FOPDT: describing function within 1%
        (lags(1.0, [10.0, 2.0], 5.0), 0.02),
        (lags(-1.0, [1.0] * 3), 0.02),  # no dead time: the phase crosses -180 through the lags
    ],
    ids=["fopdt-tau0.1", "P1", "lag-3"],
)
def test_relay_period_near_the_phase_crossover(plant, tolerance):
    result = relay_feedback(plant, rng(), amplitude=1.0)
    period, ultimate_gain = phase_crossover(plant)
    assert result.ultimate_period == pytest.approx(period, rel=tolerance)
    assert result.harmonic_ultimate_gain == pytest.approx(ultimate_gain, rel=0.05)


def test_relay_hysteresis_lengthens_the_period_and_handles_noise():
    plant = lags(1.0, [10.0, 2.0], 5.0)
    clean = relay_feedback(plant, rng(), 1.0)
    noisy = relay_feedback(plant, rng(1), 1.0, hysteresis=0.05, noise_std=0.01)
    again = relay_feedback(plant, rng(1), 1.0, hysteresis=0.05, noise_std=0.01)
    assert noisy.converged and noisy.ultimate_period == again.ultimate_period
    assert noisy.ultimate_period > clean.ultimate_period
    assert noisy.harmonic_ultimate_gain < clean.harmonic_ultimate_gain


def test_relay_excursion_and_invalid_input():
    plant = lags(1.0, [1.0], 1.0)
    result = relay_feedback(plant, rng(), 1.0, excursion_limit=0.3)
    assert result.aborted and not result.converged and abs(result.true_output[-1]) > 0.3
    with pytest.raises(ValueError, match="amplitude must be > 0"):
        relay_feedback(plant, rng(), 0.0)
    with pytest.raises(ValueError, match="hysteresis must be >= 0"):
        relay_feedback(plant, rng(), 1.0, hysteresis=-1.0)
