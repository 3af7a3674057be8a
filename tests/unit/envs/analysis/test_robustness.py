"""Robustness figures of a loop (envs.analysis.robustness, envs.analysis.loop_analysis.plant_margins).

Cross-checks, each by an independent method:

* python-control's ``stability_margins`` on an FRD of the same exact loop values on a dense grid
  (gain, phase and stability margins, their frequencies, and the delay margin
  ``min_i phi_i/omega_i`` over every gain crossover, Ingimundarson section 3);
* loops with closed-form figures: ``e^{-s}/(mu s)`` (Gorez-Klan eq. 3-12 .. 3-14: gain margin
  ``mu pi/2``, phase margin ``pi/2 - 1/mu``, delay margin ``mu pi/2 - 1``, stable iff
  ``mu > 2/pi``), ``k e^{-s}/(s + 1)`` (ultimate frequency from ``omega + atan(omega) = pi``) and
  the delay-free ``k/(s(s + 1))`` (``Ms`` and ``Mt`` from the extrema of rational functions);
* the Nyquist stability verdict and the number of unstable closed-loop poles against the roots of
  the characteristic equation found without a Pade approximation: ``np.roots`` for delay-free loops,
  the branches of the Lambert W function for ``mu s + e^{-s}`` and ``s + 1 + k e^{-s}``, and the
  growth or decay of an independent fine-step time simulation;
* the uncertainty norm bounds of Ingimundarson eq. 17 and eq. 40 against the characteristic
  equations they come from.
"""

from __future__ import annotations

import math
import warnings

import control
import numpy as np
import pytest
import scipy.optimize
import scipy.special

from agents.bench.fine_step import fine_step_response
from envs.analysis.loop_analysis import analyze, plant_margins
from envs.systems.controllers import FPPI, MSP, PID, SeriesPID
from envs.simulation.loops import loop_response
from envs.systems.plants import Plant
from envs.analysis.robustness import fppi_uncertainty_bound, loop_margins, msp_uncertainty_bound


def delayed_integrator(mu: float):
    return lambda w: np.exp(-1j * w) / (mu * 1j * w)


def delayed_lag(k: float):
    return lambda w: k * np.exp(-1j * w) / (1j * w + 1)


def _python_control_margins(omega: np.ndarray, values: np.ndarray):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # python-control warns about FRD extrapolation at the ends
        frd = control.frd(values, omega)
        return control.stability_margins(frd), control.stability_margins(frd, returnall=True)


# ----------------------------------------------------------------------------- python-control
PC_LOOPS = {
    "pid-fopdt": (Plant.from_time_constants(1.0, [1.0], 0.5), PID(1.0, 1.0, 0.1, 10.0)),
    "pi-integrating": (Plant.from_time_constants(0.5, [1.0], 1.0, integrating=True), PID(0.3, 8.0)),
    "series-pid-lag-chain": (Plant.from_time_constants(1.0, [1.0] * 4), SeriesPID(0.6, 2.0, 1.0, 10.0)),
    "series-pid-gorez-klan": (
        Plant.from_time_constants(2.0, [1.0, 0.5, 0.25, 0.125], 1.0),
        SeriesPID.gorez_klan(2.0, (1.0, 0.5), 1.4, 2.0, 10.0),
    ),
    "fppi-mismatch": (Plant.from_time_constants(1.0, [1.0, 0.5], 0.4), FPPI(1.0, 1.2, 0.7, 1.0, 1.0)),
    "fppi-unfiltered": (Plant.from_time_constants(1.0, [1.0, 0.5], 0.4), FPPI(1.0, 1.2, 0.7, 1.0, 0.0)),
    "msp-integrating": (Plant.from_time_constants(1.0, [0.5], 1.0, integrating=True), MSP(1.0, 1.5, 1.5)),
    "msp-extension": (Plant.from_time_constants(1.0, [0.5], 1.0, integrating=True), MSP(1.0, 1.5, 1.5, True)),
}


@pytest.mark.parametrize("name", PC_LOOPS)
def test_margins_agree_with_python_control(name):
    """2000 log-spaced points over four decades around ``1/T_ar``.  python-control interpolates the
    FRD with a spline, so agreement is limited by the grid: measured <= 1e-9 relative for the
    margins and crossover frequencies, <= 3e-8 for the frequency of ``Ms`` (a flat maximum)."""
    plant, controller = PC_LOOPS[name]
    margins = plant_margins(plant, controller)
    omega = np.logspace(-2, 2, 2000) / plant.step_time_scale()
    (gm, pm, sm, wpc, wgc, wms), (_, pms, _, _, wcs, _) = _python_control_margins(omega, loop_response(plant, controller, omega))
    assert margins.stable
    assert margins.gain_margin == pytest.approx(gm, rel=1e-8)
    assert margins.phase_crossover_frequency == pytest.approx(wpc, rel=1e-8)
    assert margins.phase_margin_deg == pytest.approx(pm, rel=1e-8)
    assert margins.gain_crossover_frequency == pytest.approx(wgc, rel=1e-8)
    assert margins.ms == pytest.approx(1 / sm, rel=1e-8)
    assert margins.ms_frequency == pytest.approx(wms, rel=1e-6)
    np.testing.assert_allclose(margins.gain_crossovers, np.sort(wcs), rtol=1e-8)
    delay_margin = np.min(np.radians(np.mod(pms, 360.0)) / wcs)
    assert margins.delay_margin == pytest.approx(delay_margin, rel=1e-8)


def test_delay_margin_is_the_minimum_over_every_gain_crossover():
    """A loop with three gain crossovers (a lightly damped zero pair makes ``|L|`` dip below 1 and
    come back): the delay margin is set by the third crossover, not by the first."""

    def loop(w):
        s = 1j * w
        return 2 * (s**2 + 0.04 * s + 1) * np.exp(-0.05 * s) / (s * (s + 1) * (0.2 * s + 1))

    margins = loop_margins(loop, integrators=1)
    omega = np.logspace(-3, 3, 6000)
    _, (_, pms, _, _, wcs, _) = _python_control_margins(omega, loop(omega))
    assert margins.stable and len(margins.gain_crossovers) == 3
    np.testing.assert_allclose(margins.gain_crossovers, wcs, rtol=1e-8)
    per_crossover = np.radians(np.mod(pms, 360.0)) / wcs
    assert np.argmin(per_crossover) == 2
    assert margins.delay_margin == pytest.approx(per_crossover.min(), rel=1e-8)
    assert margins.delay_margin_frequency == pytest.approx(wcs[2], rel=1e-8)


# ----------------------------------------------------------------------------- closed forms
def _rhp_roots_lambert(argument: complex, shift: float = 0.0, branches: int = 40) -> int:
    """Roots ``s = W_k(argument) - shift`` with ``Re s > 0`` over the branches ``|k| <= branches``
    (the other branches have ``Re W_k`` far in the left half plane)."""
    roots = [scipy.special.lambertw(argument, k) - shift for k in range(-branches, branches + 1)]
    return sum(r.real > 0 for r in roots)


MU_ROWS = [0.5, 0.98 * 2 / math.pi, 1.02 * 2 / math.pi, 0.8, 1.3, 2.0, 3.0, 7.0]


@pytest.mark.parametrize("mu", MU_ROWS)
def test_delayed_integrator_loop_closed_form(mu):
    """``L = e^{-s}/(mu s)``: the closed loop's poles solve ``mu s e^{s} = -1``, i.e.
    ``s = W_k(-1/mu)`` (Lambert W); stable iff ``mu > 2/pi``, on both sides of the boundary."""
    margins = loop_margins(delayed_integrator(mu), integrators=1)
    unstable = _rhp_roots_lambert(-1 / mu)
    assert margins.stable == (mu > 2 / math.pi) == (unstable == 0)
    assert margins.unstable_poles == unstable
    assert math.pi / 2 == pytest.approx(margins.phase_crossovers[0], rel=1e-9)
    if margins.stable:  # for an unstable loop gain_margin is documented as the smallest factor > 1
        assert margins.gain_margin == pytest.approx(mu * math.pi / 2, rel=1e-9)
        assert margins.phase_crossover_frequency == pytest.approx(math.pi / 2, rel=1e-9)
    assert margins.phase_margin_deg == pytest.approx(math.degrees(math.pi / 2 - 1 / mu), rel=1e-9, abs=1e-9)
    assert margins.gain_crossover_frequency == pytest.approx(1 / mu, rel=1e-9)
    if margins.stable:
        assert margins.delay_margin == pytest.approx(mu * math.pi / 2 - 1, rel=1e-9)
    else:
        assert margins.delay_margin == 0.0


@pytest.mark.parametrize("mu", [1.0, 10.0])
def test_delayed_integrator_loop_with_crossover_on_a_grid_point(mu):
    """``|L| = 1`` at ``omega = 1/mu``; for ``mu = 1`` or ``10`` that is exactly a point of the log grid
    (whole decades of ``1/time_scale``).  Observed: ``mu = 1`` gives phase and delay margins ``inf``
    (no crossover found), ``mu = 10`` raises ``ValueError: f(a) and f(b) must have different signs``."""
    margins = loop_margins(delayed_integrator(mu), integrators=1)
    assert margins.phase_margin_deg == pytest.approx(math.degrees(math.pi / 2 - 1 / mu), rel=1e-9)
    assert margins.delay_margin == pytest.approx(mu * math.pi / 2 - 1, rel=1e-9)


def test_phase_crossover_on_a_grid_point():
    """``L = 1/(s (s+1)^2)`` crosses the negative real axis at ``omega = 1`` (exactly a grid point for
    ``time_scale = 1``) with ``|L| = 1/2``: gain margin 2.  Observed: ``inf``."""
    margins = loop_margins(lambda w: 1 / (1j * w * (1j * w + 1) ** 2), integrators=1)
    assert margins.gain_margin == pytest.approx(2.0, rel=1e-9)


@pytest.mark.parametrize("kp", [1.0, 0.1])
def test_plant_level_crossover_on_a_grid_point(kp):
    """The same through the public path: ``e^{-s}/s`` with a P controller (``deadtime analyze`` gives
    ``phase_margin_deg: null`` for ``kp = 1`` and exits with "f(a) and f(b) must have different signs"
    for ``kp = 0.1``)."""
    margins = analyze(Plant([1.0], [1.0, 0.0], 1.0), PID(kp=kp, ti=None)).margins
    assert margins.phase_margin_deg == pytest.approx(math.degrees(math.pi / 2 - kp), rel=1e-9)


ULTIMATE_FREQUENCY = scipy.optimize.brentq(lambda w: w + math.atan(w) - math.pi, 1.0, 3.0)
ULTIMATE_GAIN = math.hypot(1.0, ULTIMATE_FREQUENCY)


@pytest.mark.parametrize("k", [0.3, 1.0, 0.98 * ULTIMATE_GAIN, 1.02 * ULTIMATE_GAIN, 4.0])
def test_delayed_lag_loop_ultimate_gain(k):
    """``L = k e^{-s}/(s+1)``: ``arg L = -pi`` where ``omega + atan(omega) = pi`` (omega_u = 2.0288),
    ultimate gain ``k_u = sqrt(1 + omega_u^2)`` = 2.2618; poles solve ``(s+1) e^{s+1} = -k e``,
    ``s = W_j(-k e) - 1``."""
    margins = loop_margins(delayed_lag(k), integrators=0)
    unstable = _rhp_roots_lambert(-k * math.e, shift=1.0)
    assert margins.stable == (k < ULTIMATE_GAIN) == (unstable == 0)
    assert margins.unstable_poles == unstable
    if margins.stable:
        assert margins.gain_margin == pytest.approx(ULTIMATE_GAIN / k, rel=1e-9)
        assert margins.phase_crossover_frequency == pytest.approx(ULTIMATE_FREQUENCY, rel=1e-9)
    assert margins.phase_crossovers[0] == pytest.approx(ULTIMATE_FREQUENCY, rel=1e-9)


def _k_over_s_s1_figures(k: float) -> tuple[float, float, float]:
    """``Ms``, ``Mt`` and phase margin (deg) of ``k/(s (s+1))`` in closed form.

    ``|S|^2 = x (1+x)/((k-x)^2 + x)`` with ``x = omega^2``: its maximum is at a positive root of the
    numerator of the derivative, ``(1+2x)((k-x)^2+x) - x(1+x)(2x-2k+1)``.  ``|T|^2 = k^2/((k-x)^2+x)``
    peaks at ``x = k - 1/2`` (if ``k > 1/2``).  ``|L| = 1`` at ``x^2 + x = k^2``."""
    derivative = np.polysub(
        np.polymul([2.0, 1.0], np.polyadd(np.polymul([-1.0, k], [-1.0, k]), [1.0, 0.0])),
        np.polymul([1.0, 1.0, 0.0], [2.0, 1.0 - 2.0 * k]),
    )
    candidates = [r.real for r in np.roots(derivative) if abs(r.imag) < 1e-12 and r.real > 0]
    s2 = max(x * (1 + x) / ((k - x) ** 2 + x) for x in candidates)
    t2 = k**2 / ((k - (k - 0.5)) ** 2 + (k - 0.5)) if k > 0.5 else 1.0
    crossover = math.sqrt((-1 + math.sqrt(1 + 4 * k * k)) / 2)
    return math.sqrt(s2), math.sqrt(t2), 90.0 - math.degrees(math.atan(crossover))


@pytest.mark.parametrize("k", [0.7, 1.0, 2.0, 5.0])
def test_delay_free_loop_with_known_ms(k):
    """``L = k/(s(s+1))``, e.g. ``k = 1``: ``Ms = sqrt(1 + 2/sqrt(3))`` = 1.4679, ``Mt = 2/sqrt(3)``."""
    ms, mt, pm = _k_over_s_s1_figures(k)
    margins = loop_margins(lambda w: k / (1j * w * (1j * w + 1)), integrators=1, time_scale=1.3)
    assert margins.stable
    assert margins.ms == pytest.approx(ms, rel=1e-10)
    assert margins.mt == pytest.approx(mt, rel=1e-10)
    assert margins.phase_margin_deg == pytest.approx(pm, rel=1e-10)
    assert margins.gain_margin == math.inf
    if k == 1.0:
        assert margins.ms == pytest.approx(math.sqrt(1 + 2 / math.sqrt(3)), rel=1e-12)


# ----------------------------------------------------------------------------- Nyquist vs roots
def _pid_polynomials(kp, ti, td=0.0, n=10.0):
    """``C = kp ((ti s + 1)(td s/n + 1) + ti td s^2)/(ti s (td s/n + 1))``, written out by hand."""
    if td == 0:
        return kp * np.array([ti, 1.0]), np.array([ti, 0.0])
    num = np.polyadd(np.polymul([ti, 1.0], [td / n, 1.0]), [ti * td, 0.0, 0.0])
    return kp * num, np.polymul([ti, 0.0], [td / n, 1.0])


DELAY_FREE_ROWS = {
    # name: (plant num, plant den, controller, (kp, ti, td, n))
    **{
        f"pid-lag-chain-kp{kp}": ([1.0], np.poly([-1.0] * 3), PID(kp, 2.0, 0.3, 10.0), (kp, 2.0, 0.3, 10.0))
        for kp in (0.5, 4.0, 10.0, 30.0, 80.0)
    },
    **{
        f"pi-nmp-kp{kp}": ([-2.0, 1.0], np.poly([-1.0] * 3), PID(kp, 3.0), (kp, 3.0))
        for kp in (0.2, 0.5, 1.0, 2.0)
    },
    **{
        f"pi-integrating-ti{ti}": ([1.0], [1.0, 1.0, 0.0], PID(0.5, ti), (0.5, ti))
        for ti in (0.5, 1.5, 4.0)
    },
}


@pytest.mark.parametrize("name", DELAY_FREE_ROWS)
def test_nyquist_counts_the_unstable_roots_of_the_characteristic_polynomial(name):
    num, den, controller, args = DELAY_FREE_ROWS[name]
    c_num, c_den = _pid_polynomials(*args)
    characteristic = np.polyadd(np.polymul(c_num, num), np.polymul(c_den, den))
    unstable = int(np.sum(np.roots(characteristic).real > 0))
    margins = plant_margins(Plant(num, den, 0.0), controller)
    assert margins.unstable_poles == unstable
    assert margins.stable == (unstable == 0)


@pytest.mark.parametrize("factor", [0.8, 1.25])
def test_nyquist_verdict_matches_fine_step_growth(factor):
    """PID on an FOPDT with its gain scaled to ``factor`` times the gain margin: the independent RK4
    simulation decays (``factor < 1``) or grows (``factor > 1``), as the Nyquist verdict says."""
    plant, base = Plant.from_time_constants(1.0, [1.0], 0.5), PID(1.0, 1.0, 0.1, 10.0)
    gm = plant_margins(plant, base).gain_margin
    kp = factor * gm * base.kp
    margins = plant_margins(plant, PID(kp, 1.0, 0.1, 10.0))
    run = fine_step_response(plant, PID(kp, 1.0, 0.1, 10.0), 60.0, 0.005)
    error = np.abs(run.error[:, 1])  # set-point run: e -> 0 iff stable
    t = run.timepts
    early, late = np.max(error[(t > 10) & (t <= 20)]), np.max(error[t > 50])
    assert margins.stable == (factor < 1)
    assert (late < 0.1 * early) if factor < 1 else (late > 10 * early)


# ----------------------------------------------------------------------------- other figures
def test_unstable_loop_is_reported_not_raised():
    result = analyze(Plant.from_time_constants(1.0, [1.0], 0.5), PID(kp=8.0, ti=1.0))
    assert not result.stable and result.margins.unstable_poles >= 1
    assert result.margins.delay_margin == 0.0
    assert math.isinf(result.performance.load) and math.isinf(result.performance.setpoint)


@pytest.mark.parametrize("gain", [0.1, 0.5, 0.9, 1.2])
def test_pure_dead_time_plant_with_pi(gain):
    """``P = e^{-s}``, ``C = k (1 + 1/s)`` (a biproper loop, ``|L(i inf)| = k``).  ``arg L = -pi`` first
    where ``omega + atan(1/omega) = pi``; ``|L| = k sqrt(1 + 1/omega^2)`` falls with omega, so that
    crossover sets the gain margin.  For ``k >= 1`` there are infinitely many unstable poles."""
    result = plant_margins(Plant([1.0], [1.0], 1.0), PID(kp=gain, ti=1.0))
    assert result.stable == (gain < 1)
    if gain < 1:
        first = scipy.optimize.brentq(lambda w: w + math.atan(1 / w) - math.pi, 1e-3, math.pi)
        assert result.gain_margin == pytest.approx(1 / (gain * math.hypot(1, 1 / first)), rel=1e-9)
        omega = np.logspace(-2, 3, 200_000)
        values = gain * np.exp(-1j * omega) * (1 + 1 / (1j * omega))
        assert result.ms == pytest.approx(np.max(1 / np.abs(1 + values)), rel=1e-4)


def test_fppi_uncertainty_bound_is_eq_17_from_the_characteristic_equation():
    """Eq. 16: ``1 + C F dP/(1 + C G_n) = 0``, so ``|Delta P| = |1 + C G_n|/|C F|`` (eq. 17)."""
    gain, tn, tr, tf = 1.5, 2.0, 0.8, 0.6
    omega = np.logspace(-3, 2, 100)
    s = 1j * omega
    c = tn / (gain * tr) * (1 + 1 / (tn * s))
    g = gain / (tn * s + 1)
    f = 1 / (tf * s + 1)
    np.testing.assert_allclose(fppi_uncertainty_bound(omega, gain, tn, tr, tf), np.abs(1 + c * g) / np.abs(c * f), rtol=1e-12)


def test_msp_uncertainty_bound_is_eq_40_from_the_characteristic_equation():
    """``1 + C_fb (P_n + dP) = 0`` gives ``|Delta P| = |1 + C_fb P_n|/|C_fb|`` (eq. 40)."""
    gain, ln, tr = 0.7, 1.3, 0.9
    omega = np.logspace(-3, 2, 100)
    c_fb = MSP(gain, ln, tr).feedback_response(omega)
    p_n = gain * np.exp(-1j * omega * ln) / (1j * omega)
    np.testing.assert_allclose(msp_uncertainty_bound(omega, gain, ln, tr), np.abs(1 + c_fb * p_n) / np.abs(c_fb), rtol=1e-12)


def test_packed_path_gives_the_margins_of_the_quasi_rational_path():
    """``plant_margins`` hands the loop over packed (``loop_packed``): the figures of
    ``quasi_rational_margins(loop_transfer(...))`` bit for bit."""
    from envs.analysis._robustness_kernels import quasi_rational_margins
    from envs.analysis.loop_transfer import loop_packed, loop_transfer

    stable, integrating = Plant.from_time_constants(2.0, [1.0, 0.3], 0.5), Plant.from_time_constants(1.0, [0.5], 0.5, integrating=True)
    loops = ((stable, PID(kp=0.8, ti=1.2, td=0.2)), (stable, FPPI(2.0, 1.0, 0.5, 1.0, 0.1)), (integrating, MSP(1.0, 0.8, 2.0)))
    for plant, controller in loops:
        transfer = loop_transfer(plant, controller)
        packed, shape = loop_packed(plant, controller)
        assert packed.tobytes() == transfer.packed()[0].tobytes() and shape == transfer.packed()[1]
        integrators = int(plant.integrating) + controller.integrators
        assert plant_margins(plant, controller) == quasi_rational_margins(transfer, integrators, plant.step_time_scale())


# ------------------------------------------------------------ compiled searches: exact shortcuts
def _search_loops():
    """Loops of every structure, stable and not, whose high-frequency search takes one or more decades."""
    stable, integrating = Plant.from_time_constants(1.0, [1.0, 0.5], 0.4), Plant.from_time_constants(1.0, [0.5], 1.0, integrating=True)
    loops = list(PC_LOOPS.values())
    loops += [(stable, PID(kp, 1.0, 0.2, 10.0)) for kp in (0.3, 3.0, 30.0)]
    loops += [(stable, FPPI(1.0, 1.2, 0.7, tr, tf)) for tr in (0.2, 1.0) for tf in (0.0, 0.3)]
    loops += [(integrating, MSP(1.0, 1.5, tr)) for tr in (0.5, 3.0)]
    return loops


def _prepared(plant, controller):
    from envs.analysis._robustness_kernels import _prepare
    from envs.analysis.loop_transfer import loop_transfer

    return _prepare(*loop_transfer(plant, controller).arrays), int(plant.integrating) + controller.integrators


def test_high_frequency_search_stopping_a_failed_decade_early_is_the_full_sweep():
    """A decade's sweep stops once it certainly fails: the result of sweeping every point."""
    import envs.analysis._robustness_kernels as cr

    def full_sweeps(transfer, start, points):  # the search as before the early stop
        w, top = start, math.nan
        for _ in range(14):
            first = math.log10(w)
            magnitudes = [cr._magnitude(z) for z in cr._values(transfer, cr._logspace(first, first + 1, points))]
            top, bottom = -math.inf, math.inf
            for m in magnitudes:
                top = m if m > top or math.isnan(m) else top
                bottom = m if m < bottom or math.isnan(m) else bottom
            if top < 0.02 or top - bottom < 0.01 * top:
                return w, top < 1.0
            w *= 10
        return w, top < 1.0

    for plant, controller in _search_loops():
        transfer, _ = _prepared(plant, controller)
        for start in (10.0 / plant.step_time_scale(), 1e-2 / plant.step_time_scale()):
            assert cr._high_frequency(transfer, start, cr.HIGH_FREQUENCY_POINTS) == full_sweeps(transfer, start, cr.HIGH_FREQUENCY_POINTS)


def test_low_frequency_search_as_needed_is_the_search_on_every_decade():
    """The decades evaluated one by one: the frequency found by evaluating all of them first."""
    import envs.analysis._robustness_kernels as cr

    def all_decades(transfer, integrators, start, decades):  # the search as before
        omega = [start]
        for _ in range(decades):
            omega.append(omega[-1] / 10)
        values = list(cr._values(transfer, np.array(omega)))
        for _ in range(integrators):
            values = [complex(-v.imag * w, v.real * w) for v, w in zip(values, omega)]
        for k in range(decades):
            if abs(values[k] - values[k + 1]) <= 1e-3 * max(abs(values[k + 1]), 1e-300):
                return omega[k + 1]
        return omega[decades]

    for plant, controller in _search_loops():
        transfer, integrators = _prepared(plant, controller)
        for start in (1e-3 / plant.step_time_scale(), 1e3 / plant.step_time_scale()):
            for decades in (1, 3, cr.LOW_FREQUENCY_DECADES):
                expected = all_decades(transfer, integrators, start, decades)
                assert cr._low_frequency(transfer, integrators, start, decades) == expected


def test_summed_coefficients_and_the_reused_row_give_the_evaluation_as_written():
    """``transfer_at`` with the summed coefficients prepared once (and a one-row side's polynomial
    reused) equals, bit for bit, the sums formed at every evaluation."""
    import numba

    import envs.analysis._robustness_kernels as cr

    sin_cos = numba.njit(lambda x: (math.sin(x), math.cos(x)))  # compiled as there (one sincos call)

    def side(rows, delays, w):  # _quasi_polynomial_at as written before
        re, im = 0.0, 0.0
        for k in range(rows.shape[1]):
            c = 0.0
            for i in range(rows.shape[0]):
                c += rows[i, k]
            re, im = c - im * w, re * w
        for i in range(rows.shape[0]):
            if delays[i] == 0.0:
                continue
            a_re, a_im = 0.0, 0.0
            for k in range(rows.shape[1]):
                a_re, a_im = rows[i, k] - a_im * w, a_re * w
            s, c = sin_cos(0.5 * w * delays[i])
            e_re, e_im = -2.0 * s * s, -2.0 * s * c
            re += a_re * e_re - a_im * e_im
            im += a_re * e_im + a_im * e_re
        return complex(re, im)

    omega = np.logspace(-4, 3, 57)
    for plant, controller in _search_loops():
        from envs.analysis.loop_transfer import loop_transfer

        arrays = loop_transfer(plant, controller).arrays
        expected = [side(arrays[0], arrays[1], w) / side(arrays[2], arrays[3], w) for w in omega]
        got = cr._evaluate(arrays, omega)
        assert [z.real.hex() for z in got] == [z.real.hex() for z in expected]
        assert [z.imag.hex() for z in got] == [z.imag.hex() for z in expected]


def test_crossovers_taking_log_only_at_bracket_ends_find_the_same_roots():
    """The gain brackets found from ``|L|`` against 1, with ``log |L|`` only at their ends: the
    crossovers of the tests on ``log |L|`` at every grid point, bit for bit."""
    import envs.analysis._robustness_kernels as cr

    def crossovers(transfer, omega, values):  # as before: log |L| at every point
        roots = ([], [])
        for kind in range(2):
            f = [math.log(cr._magnitude(v)) if kind == 0 else v.imag for v in values]
            for i in range(omega.size):
                if f[i] == 0:
                    roots[kind].append(omega[i])
                elif i < omega.size - 1 and f[i] * f[i + 1] < 0:
                    x = cr._chandrupatla(transfer, kind, math.log(omega[i]), math.log(omega[i + 1]), f[i], f[i + 1], cr.ROOT_XTOL, cr.MAX_ROOT_ITERATIONS)
                    roots[kind].append(math.exp(x))
        return roots

    for plant, controller in _search_loops():
        transfer, _ = _prepared(plant, controller)
        omega = np.logspace(-3, 2, 400) / plant.step_time_scale()
        values = cr._values(transfer, omega)
        magnitudes = np.array([cr._magnitude(v) for v in values])
        gains, phase = cr._crossovers(transfer, omega, values, magnitudes, cr.ROOT_XTOL, cr.MAX_ROOT_ITERATIONS)
        expected = crossovers(transfer, omega, values)
        assert gains.tolist() == expected[0] and phase.tolist() == expected[1]
    transfer, _ = _prepared(*PC_LOOPS["pid-fopdt"])  # |L| exactly 1 at a grid point, then two brackets
    omega = np.array([0.1, 0.2, 0.3, 0.4])
    values = np.array([complex(0.0, 1.0), complex(0.6, 0.0), complex(2.0, 0.0), complex(0.5, 0.0)])
    magnitudes = np.array([cr._magnitude(v) for v in values])
    gains, _ = cr._crossovers(transfer, omega, values, magnitudes, cr.ROOT_XTOL, cr.MAX_ROOT_ITERATIONS)
    assert len(gains) == 3 and gains[0] == 0.1 and gains.tolist() == crossovers(transfer, omega, values)[0]


def _three_crossover_loop():
    """``L = 17 (s + 0.1)(s + 0.14) w_r^2 / ((s + 1.25)(s + 5)(s + 0.035)(s^2 + 0.04 s + w_r^2))``,
    ``w_r = 0.25``: stable in closed loop, three gain crossovers (the lightly damped pair lifts
    ``|L|`` above 1 a second time), whose wrapped phase margins are about 168.8, -170.7 and 51.2
    degrees."""
    numerator = 17 * 0.0625 * np.poly([-0.1, -0.14])
    denominator = np.polymul(np.poly([-1.25, -5.0, -0.035]), [1.0, 0.04, 0.0625])
    return numerator, denominator


def test_phase_margin_is_python_controls_smallest_in_magnitude_over_three_crossovers():
    """python-control's ``stability_margins`` reports the phase margin smallest in magnitude
    (``control/margins.py``), not the most negative: 51.2 degrees here, where the most negative
    wrapped margin is -170.7.  Both of our paths (numpy and compiled) agree with its exact
    (polynomial) crossovers: measured <= 1.4e-15 relative, asserted 1e-12 (the crossovers are
    located to ``ROOT_XTOL = 1e-13`` in log frequency)."""
    from envs.analysis._robustness_kernels import quasi_rational_margins
    from envs.analysis.loop_transfer import QuasiRational

    numerator, denominator = _three_crossover_loop()
    tf = control.tf(numerator, denominator)
    assert np.all(control.feedback(tf).poles().real < 0)
    _, pm, _, _, wgc, _ = control.stability_margins(tf)
    _, pms, _, _, wgcs, _ = control.stability_margins(tf, returnall=True)
    assert len(pms) == 3 and min(pms) < -170 and pm == pytest.approx(51.16, abs=0.01)
    transfer = QuasiRational(((tuple(numerator), 0.0),), ((tuple(denominator), 0.0),))
    for margins in (loop_margins(lambda w: tf(1j * w), integrators=0), quasi_rational_margins(transfer, integrators=0)):
        assert margins.stable
        assert margins.phase_margin_deg == pytest.approx(pm, rel=1e-12)
        assert margins.gain_crossover_frequency == pytest.approx(wgc, rel=1e-12)
        np.testing.assert_allclose(margins.gain_crossovers, wgcs, rtol=1e-12)
        np.testing.assert_allclose(margins.phase_margins_deg, pms, rtol=1e-12)


@pytest.mark.parametrize("delay", [0.0, 1e-4])
def test_ms_is_never_reported_below_one(delay):
    """``P = 1/(s + 1)``, PI ``kp = 0.5, ti = 1``, so ``L = 0.5 e^{-Ls}/s``: ``|S| < 1`` at
    every finite frequency of the delay-free loop and ``sup |S| = 1`` (reached as ``w -> inf``; never
    reported below it, as 0.99911).  With ``L = 1e-4`` the peak sits beyond the grid's end (``|L| < 0.02``):
    Ms is within 2% (python-control on a Pade model gives 1.00013)."""
    margins = plant_margins(Plant.from_time_constants(1.0, [1.0], delay), PID(0.5, 1.0))
    assert 1.0 <= margins.ms <= 1 / 0.98
    if delay == 0.0:
        assert margins.ms == 1.0 and margins.ms_frequency == math.inf
