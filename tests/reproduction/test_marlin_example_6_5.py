"""Marlin, Process Control (2nd ed.), Example 6.5 (section 6.4): the least-squares fit of the
stirred tank's step test, sampled at 0.333 min.

The book prints the regression for dead times of 7 to 10 samples (a = 0.964, 0.9605, 0.9578,
0.9555; b = 0.101, 0.108, 0.1143, 0.1196; sum of squared errors 7.52, 6.33, 5.86, 6.21), chooses 9
samples (the smallest sum), and computes back ``theta = 9 (0.333) = 3 min``,
``tau = 0.333/0.0431 = 7.7 min`` and ``K_p = 0.1143/(1 - 0.9578) = 2.7 degC/%open``.  Its data (the
tank of Figure 6.3, stepped by 5% open) are not printed, so the tests step the plant on the
project's exact simulation (``open_loop_step`` sampled at 0.333) and fit the record:

* the plant of the book's unrounded results, ``K_p = 0.1143/(1 - 0.9578)``,
  ``tau = -0.333/ln 0.9578``, ``theta = 9 (0.333)``, gives the printed ``a`` and ``b`` to their four
  digits, ``Gamma = 9``, and back ``K_p``, ``tau``, ``theta`` to their printed digits;
* the rounded plant ``2.7 e^{-3s}/(7.7 s + 1)`` gives ``Gamma = 9`` and back 2.7, 7.7 and 3.0 to the
  printed digits, but ``a = 0.9577`` and ``b = 0.1142``, each one unit of the fourth digit from the
  book: its exact discrete pole is ``e^{-0.333/7.7} = 0.95768`` (the book's 0.9578 is
  ``e^{-0.333/7.72}``: its ``tau`` was 7.72, printed 7.7), and its dead time of 3.0 min is 9.009
  samples, not 9, so that the one-sample regression misses a 0.009-sample sliver of the step and
  gives ``b`` 8e-5 below ``K_p (1 - a) = 0.11428``.
The other rows of the book's table (Gamma = 7, 8, 10) come from its noisy data and are not
reproduced; the shape is (the criterion is smallest at 9 and grows on both sides).
"""

import math

import numpy as np
import pytest

from envs.identification.least_squares import METHODS, least_squares_fit
from envs.identification.open_loop_step import open_loop_step
from envs.systems.plants import Plant

DT = 0.333  # min (Example 6.5)
STEP = 5.0  # % open (Example 6.1, Figure 6.3)
PRINTED_A, PRINTED_B, PRINTED_DELAY = 0.9578, 0.1143, 9
BOOK_PLANT = (PRINTED_B / (1 - PRINTED_A), -DT / math.log(PRINTED_A), PRINTED_DELAY * DT)
ROUNDED_PLANT = (2.7, 7.7, 3.0)


def _fit(gain: float, time_constant: float, dead_time: float, method: str, delays=range(7, 11)):
    plant = Plant(num=(gain,), den=(time_constant, 1.0), dead_time=dead_time)
    record = open_loop_step(plant, np.random.default_rng(0), STEP, plant.residence_time, gain, dt=DT)
    assert record.settled and not record.aborted
    return least_squares_fit(record.control, record.output, DT, method=method, delays=delays, exhaustive=True)


def _printed(value: float, digits: int) -> float:
    return round(value, digits)


@pytest.mark.parametrize("method", METHODS)
def test_book_plant_gives_the_printed_regression_and_model(method):
    fit = _fit(*BOOK_PLANT, method)
    a, b = fit.coefficients
    assert fit.delay == PRINTED_DELAY
    assert (_printed(a, 4), _printed(b, 4)) == (PRINTED_A, PRINTED_B)
    model = fit.model
    assert (_printed(model.gain, 1), _printed(model.time_constant, 1), _printed(model.dead_time, 1)) == (2.7, 7.7, 3.0)
    assert _printed(-math.log(a), 4) == 0.0431  # the book's "ln a" (0.333/0.0431 = 7.7)


@pytest.mark.parametrize("method", METHODS)
def test_rounded_plant_gives_the_printed_model(method):
    fit = _fit(*ROUNDED_PLANT, method)
    a, b = fit.coefficients
    assert fit.delay == PRINTED_DELAY
    model = fit.model
    assert (_printed(model.gain, 1), _printed(model.time_constant, 1), _printed(model.dead_time, 1)) == (2.7, 7.7, 3.0)
    # One unit of the fourth digit from the book (module docstring): the exact pole and the sliver.
    assert _printed(a, 4) == 0.9577 and a == pytest.approx(math.exp(-DT / 7.7), abs=5e-5)
    assert _printed(b, 4) == 0.1142 and b == pytest.approx(2.7 * (1 - math.exp(-DT / 7.7)), abs=1.5e-4)


@pytest.mark.parametrize("plant", [BOOK_PLANT, ROUNDED_PLANT], ids=["book", "rounded"])
def test_marlins_criterion_is_smallest_at_nine_samples_and_grows_on_both_sides(plant):
    fit = _fit(*plant, "least-squares", delays=range(5, 14))
    variance = {c.delay: c.residual_variance for c in fit.candidates}
    assert min(variance, key=variance.get) == PRINTED_DELAY
    below = [variance[g] for g in range(5, 10)]
    above = [variance[g] for g in range(9, 14)]
    assert all(x > y for x, y in zip(below, below[1:])) and all(x < y for x, y in zip(above, above[1:]))


def test_the_default_search_finds_the_same_dead_time():
    """Searching every dead time of half the record (not only the book's rows) finds 9 samples too."""
    plant = Plant(num=(BOOK_PLANT[0],), den=(BOOK_PLANT[1], 1.0), dead_time=BOOK_PLANT[2])
    record = open_loop_step(plant, np.random.default_rng(0), STEP, plant.residence_time, BOOK_PLANT[0], dt=DT)
    for method in METHODS:
        assert least_squares_fit(record.control, record.output, DT, method=method).delay == PRINTED_DELAY
