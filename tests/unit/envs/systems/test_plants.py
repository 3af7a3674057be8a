"""Plants ``G(s) e^{-L s}`` (envs.systems.plants): validation, moments, frequency response, realization.

Reference values: the average residence time ``T_ar = -p1`` and ``p2`` of ``P(s)/K = 1 + p1 s +
p2 s^2 + ...`` (Gorez-Klan eq. 2-3 .. 2-5, Ingimundarson eq. 5) are checked against a power series
of ``num/den`` computed by long division here, and against the closed forms ``T_ar = sum T_k -
sum T0_j + L`` of factored plants.
"""

from __future__ import annotations

import math

import control
import numpy as np
import pytest

from envs.systems.plants import Plant


# ----------------------------------------------------------------------------- validation
# (constructor arguments, regex naming the field)
BAD_PLANTS = {
    "improper": (([1.0, 2.0, 3.0], [1.0, 1.0], 1.0), r"^num\b.*proper"),
    "unstable-pole": (([1.0], [1.0, -1.0], 1.0), r"^den\b.*unstable"),
    "unstable-pair": (([1.0], [1.0, -0.2, 1.0], 0.0), r"^den\b.*unstable"),
    "poles-on-imaginary-axis": (([1.0], [1.0, 0.0, 1.0], 1.0), r"^den\b.*unstable"),
    "integrator-and-unstable-pole": (([1.0], [1.0, -1.0, 0.0], 1.0), r"^den\b.*unstable"),
    "two-integrators": (([1.0], [1.0, 0.0, 0.0], 1.0), r"^den\b.*integrator"),
    "three-integrators": (([1.0], [1.0, 2.0, 0.0, 0.0, 0.0], 0.0), r"^den\b.*integrator"),
    "nan-num": (([math.nan], [1.0, 1.0], 1.0), r"^num\b.*finite"),
    "inf-den": (([1.0], [math.inf, 1.0], 1.0), r"^den\b.*finite"),
    "nan-dead-time": (([1.0], [1.0, 1.0], math.nan), r"^dead_time\b"),
    "inf-dead-time": (([1.0], [1.0, 1.0], math.inf), r"^dead_time\b"),
    "negative-dead-time": (([1.0], [1.0, 1.0], -0.5), r"^dead_time\b.*>= 0"),
    "zero-gain-all-zero": (([0.0, 0.0], [1.0, 1.0], 1.0), r"^num\b"),
    "zero-gain-zero-at-origin": (([1.0, 0.0], [1.0, 1.0], 1.0), r"^num\b.*zero"),
    "zero-velocity-gain": (([1.0, 0.0], [1.0, 1.0, 0.0], 1.0), r"^num\b.*zero"),
    "empty-den": (([1.0], [], 1.0), r"^den\b"),
    "all-zero-den": (([1.0], [0.0, 0.0], 1.0), r"^den\b"),
    "non-numeric-num": ((["a"], [1.0, 1.0], 1.0), r"^num\b"),
    "non-numeric-dead-time": (([1.0], [1.0, 1.0], "soon"), r"^dead_time\b"),
}


@pytest.mark.parametrize("name", BAD_PLANTS)
def test_plant_refuses_invalid_data_naming_the_field(name):
    args, pattern = BAD_PLANTS[name]
    with pytest.raises(ValueError, match=pattern):
        Plant(*args)


BAD_DICTS = {
    "not-an-object": ([1.0], r"^plant\b"),
    "missing-delay": ({"num": [1.0], "den": [1.0, 1.0]}, r"missing key 'delay'"),
    "unknown-key": ({"num": [1.0], "den": [1.0, 1.0], "delay": 1.0, "gain": 2.0}, r"unknown key 'gain'"),
    "num-not-a-list": ({"num": 1.0, "den": [1.0, 1.0], "delay": 1.0}, r"plant\.num"),
    "num-string": ({"num": ["1"], "den": [1.0, 1.0], "delay": 1.0}, r"plant\.num"),
    "den-bool": ({"num": [1.0], "den": [True, 1.0], "delay": 1.0}, r"plant\.den"),
    "delay-bool": ({"num": [1.0], "den": [1.0, 1.0], "delay": True}, r"plant\.delay"),
    "delay-string": ({"num": [1.0], "den": [1.0, 1.0], "delay": "1"}, r"plant\.delay"),
    "delay-nan": ({"num": [1.0], "den": [1.0, 1.0], "delay": math.nan}, r"plant\.delay"),
    "delay-negative": ({"num": [1.0], "den": [1.0, 1.0], "delay": -1}, r"plant\.delay"),
    "improper": ({"num": [1.0, 0.5, 1.0], "den": [1.0, 1.0], "delay": 1.0}, r"plant\.num"),
    "unstable": ({"num": [1.0], "den": [1.0, -2.0], "delay": 1.0}, r"plant\.den"),
    "two-integrators": ({"num": [1.0], "den": [1.0, 0.0, 0.0], "delay": 1.0}, r"plant\.den"),
    "zero-gain": ({"num": [0.0], "den": [1.0, 1.0], "delay": 1.0}, r"plant\.num"),
    "nan-coefficient": ({"num": [math.nan], "den": [1.0, 1.0], "delay": 1.0}, r"plant\.num"),
}


@pytest.mark.parametrize("name", BAD_DICTS)
def test_plant_from_dict_refuses_invalid_json_naming_the_field(name):
    data, pattern = BAD_DICTS[name]
    with pytest.raises(ValueError, match=pattern):
        Plant.from_dict(data)


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"gain": 0.0, "time_constants": [1.0]}, r"^gain\b"),
        ({"gain": math.nan, "time_constants": [1.0]}, r"^gain\b"),
        ({"gain": 1.0, "time_constants": [1.0, -2.0]}, r"^time_constants\b"),
        ({"gain": 1.0, "time_constants": [0.0]}, r"^time_constants\b"),
        ({"gain": 1.0, "time_constants": [math.inf]}, r"^time_constants\b"),
        ({"gain": 1.0, "time_constants": [1.0], "zero_time_constants": [math.nan]}, r"^zero_time_constants\b"),
        ({"gain": 1.0, "time_constants": [1.0], "dead_time": -1.0}, r"^dead_time\b"),
        ({"gain": 1.0, "time_constants": [1.0], "zero_time_constants": [1.0, 2.0]}, r"^num\b.*proper"),
    ],
)
def test_from_time_constants_refuses_invalid_data(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        Plant.from_time_constants(**kwargs)


def test_coefficients_are_normalized():
    plant = Plant(num=[0.0, 4.0], den=[0.0, 2.0, 1.0], dead_time=3)
    assert plant.num == (2.0,) and plant.den == (1.0, 0.5) and plant.dead_time == 3.0
    assert plant.gain == 4.0


# ----------------------------------------------------------------------------- moments
def _series(num, den, terms: int = 3) -> np.ndarray:
    """Power series of ``num(s)/den(s)`` (descending coefficients) by long division of ascending ones."""
    n = np.zeros(terms)
    d = np.zeros(terms)
    asc_n, asc_d = np.asarray(num, float)[::-1], np.asarray(den, float)[::-1]
    n[: min(terms, asc_n.size)] = asc_n[:terms]
    d[: min(terms, asc_d.size)] = asc_d[:terms]
    c = np.zeros(terms)
    for k in range(terms):
        c[k] = (n[k] - np.dot(d[1 : k + 1], c[k - 1 :: -1][:k])) / d[0]
    return c


MOMENT_ROWS = {
    # name: (plant, T_ar in closed form)
    "fopdt": (Plant.from_time_constants(2.0, [3.0], 1.5), 4.5),
    "lag-chain": (Plant.from_time_constants(1.0, [0.7] * 5, 0.2), 3.7),
    "gorez-klan-chain": (Plant.from_time_constants(1.0, [1.0, 0.5, 0.25, 0.125], 0.0), 1.875),
    "nmp": (Plant.from_time_constants(1.0, [1.0] * 3, 0.0, zero_time_constants=[-2.0]), 5.0),
    "lead": (Plant.from_time_constants(-3.0, [2.0, 1.0], 0.5, zero_time_constants=[0.4]), 3.1),
    "underdamped": (Plant([1.0], [1.0, 0.6, 1.0], 0.3), 0.9),
    "integrating": (Plant.from_time_constants(0.5, [2.0, 1.0], 5.0, integrating=True), 8.0),
    "ingimundarson-p7": (Plant([0.55, 0.1], np.polymul([1.0, 1.0], [1.0, 0.1]), 0.0), 1 / 0.1 + 1 - 0.55 / 0.1),
}


@pytest.mark.parametrize("name", MOMENT_ROWS)
def test_residence_time_and_taylor_coefficients(name):
    plant, residence_time = MOMENT_ROWS[name]
    num, den = plant.num, plant.den
    if plant.integrating:
        den = den[:-1]
    series = _series(num, den)  # G(s) without the integrator
    with_delay = np.convolve(series, [1.0, -plant.dead_time, plant.dead_time**2 / 2])[:3] / series[0]
    p1, p2 = plant.taylor_coefficients()
    assert plant.gain == pytest.approx(series[0], rel=1e-12)
    assert p1 == pytest.approx(with_delay[1], rel=1e-12, abs=1e-12)
    assert p2 == pytest.approx(with_delay[2], rel=1e-12, abs=1e-12)
    assert plant.residence_time == pytest.approx(residence_time, rel=1e-12)


def test_step_time_scale_is_positive_when_the_residence_time_is_not():
    """A strong lead ``(1 + 5 s)/(1 + s)`` has ``T_ar = -4``; the time scale falls back to the slowest pole."""
    plant = Plant.from_time_constants(1.0, [1.0], 0.0, zero_time_constants=[5.0])
    assert plant.residence_time == pytest.approx(-4.0)
    assert plant.step_time_scale() == pytest.approx(1.0)


# ----------------------------------------------------------------------------- responses
@pytest.mark.parametrize("name", MOMENT_ROWS)
def test_frequency_response_and_realization(name):
    """``frequency_response`` is ``num/den e^{-i omega L}``; the realization ``C (sI - A)^{-1} B + D``
    reproduces ``num/den``."""
    plant, _ = MOMENT_ROWS[name]
    omega = np.logspace(-3, 2, 80)
    s = 1j * omega
    rational = np.polyval(plant.num, s) / np.polyval(plant.den, s)
    np.testing.assert_allclose(plant.frequency_response(omega), rational * np.exp(-s * plant.dead_time), rtol=1e-12)
    ss = plant.state_space()
    n = ss.A.shape[0]
    realized = np.array([(ss.C @ np.linalg.solve(x * np.eye(n) - ss.A, ss.B) + ss.D)[0, 0] for x in s])
    np.testing.assert_allclose(realized, rational, rtol=1e-10)


def test_factored_constructor_matches_coefficients():
    plant = Plant.from_time_constants(2.0, [3.0, 0.5], 1.0, zero_time_constants=[-1.5], integrating=True)
    expected_num = 2.0 * np.array([-1.5, 1.0])
    expected_den = np.polymul(np.polymul([3.0, 1.0], [0.5, 1.0]), [1.0, 0.0])
    omega = np.logspace(-2, 2, 30)
    s = 1j * omega
    np.testing.assert_allclose(
        plant.frequency_response(omega), np.polyval(expected_num, s) / np.polyval(expected_den, s) * np.exp(-s), rtol=1e-12
    )
    assert plant.integrating and plant.gain == pytest.approx(2.0)


def test_from_transfer_function_and_dict_round_trip():
    tf = control.tf([1.0, 2.0], [1.0, 3.0, 2.0, 0.0])
    plant = Plant.from_transfer_function(tf, dead_time=0.7)
    assert plant == Plant([1.0, 2.0], [1.0, 3.0, 2.0, 0.0], 0.7)
    assert Plant.from_dict(plant.to_dict()) == plant
    with pytest.raises(ValueError, match="continuous"):
        Plant.from_transfer_function(control.tf([1.0], [1.0, 0.5], 0.1))
