"""The vectorized and compiled fast paths against the straightforward methods they replace.

* :func:`envs.analysis.robustness._bracketed_roots` (all crossings at once) against ``scipy.optimize.brentq``
  on each bracket, and :func:`envs.analysis.robustness._peaks` against a dense evaluation and bounded Brent;
* the figures of :func:`envs.analysis.robustness.loop_margins` against a point-by-point reference built on
  ``brentq`` and ``minimize_scalar`` (the method used before the vectorization);
* the compiled analysis of a plant-controller loop (:func:`envs.analysis.loop_analysis.plant_margins`,
  :mod:`envs.analysis._robustness_kernels`) against :func:`envs.analysis.robustness.loop_margins` on a few hundred
  random loops of every controller type, and against the point-by-point reference;
* :func:`envs.identification.commissioning._first_violation` against the table of ``max |1/(1 + k L)|`` over
  gains and frequencies in complex arithmetic;
* the compiled recursion of :func:`envs.simulation.open_loop.open_loop_response` against the same recursion
  written as a Python loop.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.optimize

from baselines.oracle import exact_models
from envs.analysis.loop_analysis import plant_margins
from envs.identification.commissioning import _first_violation
from envs.systems.controllers import FPPI, MSP, PID, SeriesPID
from envs.structures import PARAMETER_RANGES, design, relative_scale
from envs.systems.families import FAMILIES, sample_plants
from envs.simulation.loops import loop_response
from envs.systems.plants import Plant
from envs.analysis.robustness import _bracketed_roots, _peaks, _refine, frequency_grid, loop_margins
from envs.simulation.discretization import delayed_zoh
from envs.simulation.open_loop import open_loop_response


# ----------------------------------------------------------------------------- roots and peaks
ROOT_FUNCTIONS = {
    "cubic": lambda x: x**3 - 2 * x - 5,
    "oscillating": lambda x: np.sin(7 * x) + 0.3 * x,
    "steep": lambda x: np.tanh(40 * (x - 0.123)),
    "flat-near-root": lambda x: (x - 0.7) ** 3,
}


@pytest.mark.parametrize("name", ROOT_FUNCTIONS)
def test_bracketed_roots_agree_with_brentq(name):
    fun = ROOT_FUNCTIONS[name]
    grid = np.linspace(-3.0, 3.0, 61)
    values = fun(grid)
    i = np.flatnonzero(values[:-1] * values[1:] < 0)
    assert i.size > 0
    roots = _bracketed_roots(lambda x, j: fun(x), grid[i], grid[i + 1], values[i], values[i + 1])
    expected = [scipy.optimize.brentq(fun, grid[k], grid[k + 1], xtol=1e-14) for k in i]
    # a triple root is only defined to about eps^(1/3) by the function values
    tolerance = 1e-4 if name == "flat-near-root" else 1e-12
    np.testing.assert_allclose(roots, expected, rtol=0, atol=tolerance)


def test_peaks_refine_to_the_maxima_of_a_dense_evaluation():
    loop = lambda w: 2.5 * np.exp(-1j * w) / (1j * w + 1)  # noqa: E731
    measures = (lambda w: 1 / np.abs(1 + loop(w)), lambda w: np.abs(loop(w) / (1 + loop(w))))
    omega = np.logspace(-1, 1, 41)
    dense = np.logspace(-1, 1, 2_000_001)
    for (value, frequency), measure in zip(_peaks(loop, omega, loop(omega)), measures):
        assert value >= measure(dense).max() * (1 - 1e-12)
        i = int(np.argmax(measure(omega)))
        result = scipy.optimize.minimize_scalar(lambda x: -measure(np.array([math.exp(x)]))[0], method="bounded",
                                                bounds=(math.log(omega[i - 1]), math.log(omega[i + 1])),
                                                options={"xatol": 1e-12})  # fmt: skip
        assert value == pytest.approx(-result.fun, rel=1e-12)
        assert frequency == pytest.approx(math.exp(result.x), rel=1e-6)


# ----------------------------------------------------------------------------- margins
def _reference_margins(loop, integrators: int, time_scale: float) -> dict[str, float]:
    """Crossovers by ``brentq`` one bracket at a time and peaks by bounded Brent, on the same grid."""
    omega, _ = frequency_grid(loop, integrators, time_scale)
    omega, values = _refine(loop, omega, loop(omega))

    def crossings(fun, samples):
        roots = list(omega[samples == 0])
        for i in np.flatnonzero(samples[:-1] * samples[1:] < 0):
            f = lambda x: fun(np.array([math.exp(x)]))[0]  # noqa: E731
            roots.append(math.exp(scipy.optimize.brentq(f, math.log(omega[i]), math.log(omega[i + 1]), xtol=1e-14)))
        return np.sort(roots)

    def peak(fun, samples):
        i = int(np.argmax(samples))
        lo, hi = math.log(omega[max(i - 1, 0)]), math.log(omega[min(i + 1, omega.size - 1)])
        result = scipy.optimize.minimize_scalar(lambda x: -fun(np.array([math.exp(x)]))[0], bounds=(lo, hi),
                                                method="bounded", options={"xatol": 1e-13})  # fmt: skip
        return max(-result.fun, samples[i])

    gains = crossings(lambda w: np.log(np.abs(loop(w))), np.log(np.abs(values)))
    phase = crossings(lambda w: loop(w).imag, values.imag)
    phase = phase[loop(phase).real < 0] if phase.size else phase
    factors = [1 / abs(loop(np.array([w]))[0]) for w in phase]
    angles = np.angle(loop(gains)) if gains.size else np.array([])
    return {
        "ms": peak(lambda w: 1 / np.abs(1 + loop(w)), 1 / np.abs(1 + values)),
        "mt": peak(lambda w: np.abs(loop(w) / (1 + loop(w))), np.abs(values / (1 + values))),
        "gain_margin": min([f for f in factors if f > 1], default=math.inf),
        "phase_margin_deg": math.degrees(min(((angles + 2 * math.pi) % (2 * math.pi)) - math.pi, key=abs, default=math.inf)),
        "delay_margin": min(((angles + math.pi) % (2 * math.pi)) / gains, default=math.inf),
        "crossovers": len(gains),
    }


MARGIN_LOOPS = {
    "series-pid-fopdt": (Plant.from_time_constants(1.0, [1.0], 0.4), SeriesPID(2.0, 1.0, 0.2, 10.0)),
    "pid-lag-chain": (Plant.from_time_constants(-2.0, [1.0, 0.5, 0.25, 0.125], 1.0), PID(-0.4, 1.5, 0.3, 10.0)),
    "fppi-nmp": (Plant(num=[-1.0, 1.0], den=[1.0, 3.0, 3.0, 1.0], dead_time=0.5), FPPI(1.0, 2.5, 1.0, 0.8, 0.8)),
    "msp-integrating": (Plant.from_time_constants(1.0, [1.0], 2.0, integrating=True), MSP(1.0, 3.0, 2.0)),
    "resonant-pid": (Plant(num=[9.0], den=[1.0, 3.0, 11.0, 9.0], dead_time=0.3), SeriesPID(0.5, 1.0, 0.1, 10.0)),
}


@pytest.mark.parametrize("name", MARGIN_LOOPS)
def test_margins_agree_with_the_point_by_point_reference(name):
    plant, controller = MARGIN_LOOPS[name]
    loop = lambda w: loop_response(plant, controller, w)  # noqa: E731
    integrators = int(plant.integrating) + controller.integrators
    fast = loop_margins(loop, integrators, plant.step_time_scale())
    reference = _reference_margins(loop, integrators, plant.step_time_scale())
    assert len(fast.gain_crossovers) == reference["crossovers"]
    for key in ("ms", "mt", "gain_margin", "phase_margin_deg", "delay_margin"):
        assert getattr(fast, key) == pytest.approx(reference[key], rel=1e-10), key


# ----------------------------------------------------------------------------- compiled margins
def _random_loops(per_family: int, seed: int):
    """``(name, plant, controller)``: plants of every family of :func:`envs.systems.families.sample_plants`,
    designs of :func:`envs.structures.design` on their exact models (:func:`baselines.oracle.exact_models`)
    with the relative parameter log-uniform from a tenth of the low end of its range to its high end
    (many unstable or infeasible), an MSP with the PD-type filter (eq. 51) on a mismatched model, and
    an ideal PID of random gain (often unstable)."""
    rng = np.random.default_rng(seed)
    for family in FAMILIES:
        for i, plant in enumerate(sample_plants(family, per_family, seed)):
            models = exact_models(plant)
            choices = [("msp", models.integrating_model)] if plant.integrating else [("pid", models.sopdt), ("fppi", models.fopdt)]
            for structure, model in choices:
                low, high = PARAMETER_RANGES[structure]
                for k in range(2):
                    relative = math.exp(rng.uniform(math.log(low / 10), math.log(high)))
                    yield f"{family}-{i}-{structure}-{k}", plant, design(structure, model, relative * relative_scale(structure, model))
            if plant.integrating:
                tr = math.exp(rng.uniform(math.log(0.01), math.log(30))) * models.integrating_model.dead_time
                model = models.integrating_model
                yield f"{family}-{i}-msp-extension", plant, MSP(model.gain * rng.uniform(0.5, 2), model.dead_time * rng.uniform(0.5, 2), tr, True)
            scale = abs(plant.gain) * (plant.residence_time if plant.integrating else 1.0)
            kp = math.copysign(math.exp(rng.uniform(math.log(0.05), math.log(20))) / scale, plant.gain)
            t = plant.residence_time
            yield f"{family}-{i}-ideal-pid", plant, PID(kp, t * rng.uniform(0.2, 3), t * rng.uniform(0, 0.5), 10.0)


def _relative(a: float, b: float) -> float:
    return 0.0 if a == b else abs(a - b) / abs(b)


def test_compiled_margins_agree_with_loop_margins_on_random_loops():
    """:func:`envs.analysis.loop_analysis.plant_margins` (compiled, on the quasi-rational loop) against
    :func:`envs.analysis.robustness.loop_margins` on ``loop_response`` over some 250 loops (about 40 % unstable).

    Tolerances, from the conditioning of the figures (measured maxima over 1144 such loops in
    brackets): equal verdicts, numbers of unstable poles and of crossovers; crossover frequencies
    ``1e-12`` (``1e-13``); gain, phase and delay margins ``1e-9`` (``6e-11``: ``L`` itself is only
    defined to ``eps omega L`` by the phase of its dead times); ``Ms`` and ``Mt`` ``1e-11`` times
    their value (an error ``delta`` in ``L`` moves ``|1 + L|`` by ``delta |L|``; ``2e-9`` at
    ``Ms = 1656``); their frequencies ``1e-5`` (``1.2e-6``: a maximum is flat, its abscissa defined
    to about ``sqrt(eps)``), and only for a peak above 1 (``Mt`` is often largest, at ``1 - 1e-16``,
    on the plateau at low frequencies, where its frequency is arbitrary).  Phase crossovers are
    compared where ``|L| > 0.05``: at high frequencies the grid is coarse for the dead time's phase
    and a bracket can hold three roots, of which the two methods may find different ones.
    """
    count = unstable = 0
    for name, plant, controller in _random_loops(8, 3):
        integrators = int(plant.integrating) + controller.integrators
        expected = loop_margins(lambda w: loop_response(plant, controller, w), integrators, plant.step_time_scale())  # noqa: B023
        actual = plant_margins(plant, controller)
        count, unstable = count + 1, unstable + (not expected.stable)
        assert (actual.stable, actual.unstable_poles) == (expected.stable, expected.unstable_poles), name
        assert len(actual.gain_crossovers) == len(expected.gain_crossovers), name
        assert len(actual.phase_crossovers) == len(expected.phase_crossovers), name
        np.testing.assert_allclose(actual.gain_crossovers, expected.gain_crossovers, rtol=1e-12, err_msg=name)
        magnitudes = np.abs(loop_response(plant, controller, np.array(expected.phase_crossovers)))
        np.testing.assert_allclose(
            np.array(actual.phase_crossovers)[magnitudes > 0.05], np.array(expected.phase_crossovers)[magnitudes > 0.05], rtol=1e-12, err_msg=name
        )
        for key in ("gain_margin", "phase_margin_deg", "delay_margin", "gain_crossover_frequency", "phase_crossover_frequency", "delay_margin_frequency"):
            assert _relative(getattr(actual, key), getattr(expected, key)) <= 1e-9 or math.isnan(getattr(expected, key)), (name, key)
        for peak in ("ms", "mt"):
            value = getattr(expected, peak)
            assert _relative(getattr(actual, peak), value) <= 1e-11 * max(value, 1.0), (name, peak)
            if value > 1 + 1e-6:
                assert _relative(getattr(actual, f"{peak}_frequency"), getattr(expected, f"{peak}_frequency")) <= 1e-5, (name, peak)
    assert count > 200 and 0.2 * count < unstable < 0.6 * count


@pytest.mark.parametrize("name", MARGIN_LOOPS)
def test_compiled_margins_agree_with_the_point_by_point_reference(name):
    plant, controller = MARGIN_LOOPS[name]
    loop = lambda w: loop_response(plant, controller, w)  # noqa: E731
    compiled = plant_margins(plant, controller)
    reference = _reference_margins(loop, int(plant.integrating) + controller.integrators, plant.step_time_scale())
    assert len(compiled.gain_crossovers) == reference["crossovers"]
    for key in ("ms", "mt", "gain_margin", "phase_margin_deg", "delay_margin"):
        assert getattr(compiled, key) == pytest.approx(reference[key], rel=1e-10), key


# ----------------------------------------------------------------------------- commissioning
@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("delay", [0.0, 0.4, 0.8, 3.0])
@pytest.mark.parametrize("target", [1.2, 1.4, 2.0])
def test_first_violation_agrees_with_the_table_of_sensitivities(sign, delay, target):
    omega = np.logspace(-3, 2, 500)
    plant = Plant.from_time_constants(sign * 1.5, [1.0, 0.2], delay)
    loop = sign * plant.frequency_response(omega) * (1 + 1 / (1j * omega))
    gains = np.geomspace(1e-3, 3.0, 60)
    sensitivity = np.max(1 / np.abs(1 + gains[:, None] * loop[None, :]), axis=1)
    bad = np.flatnonzero(sensitivity > target)
    assert _first_violation(loop, gains, target) == (bad[0] if bad.size else gains.size)


def test_first_violation_without_any():
    omega = np.logspace(-3, 2, 500)
    loop = 1 / (1j * omega + 1)  # Re L > 0: |1 + k L| > 1 for every k > 0
    assert _first_violation(loop, np.geomspace(1e-3, 3.0, 60), 1.1) == 60


# ----------------------------------------------------------------------------- open-loop recursion
@pytest.mark.parametrize("delay", [0.0, 0.3, 0.35, 1.0])
def test_compiled_open_loop_recursion_matches_the_python_loop(delay):
    plant = Plant(num=[-0.5, 1.0], den=[1.0, 2.2, 1.7, 0.5], dead_time=delay)
    ss = plant.state_space()
    dt = 0.1
    u = np.where(np.arange(300) < 120, 1.5, -0.25)
    Phi, g0, g1, m = delayed_zoh(ss, delay, dt)
    padded = np.concatenate([np.zeros(m + 1), u])
    x, expected = np.zeros(ss.A.shape[0]), []
    for j in range(u.size):
        now, before = padded[j + 1], padded[j]
        expected.append(float((ss.C @ x)[0]) + ss.D[0, 0] * (before if np.any(g1) else now))
        x = Phi @ x + g0.ravel() * now + g1.ravel() * before
    np.testing.assert_allclose(open_loop_response(ss, delay, u, dt), expected, rtol=1e-12, atol=1e-14)
