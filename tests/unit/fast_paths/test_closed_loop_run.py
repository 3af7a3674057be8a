"""The compiled closed-loop step run and recursion against the readable paths, bit for bit.

* :func:`envs.identification.closed_loop_run._run_closed_loop` (compiled calls of
  :func:`envs.simulation._run_kernels._closed_loop_run`) against ``method="reference"``, the chunked run it
  replaced (:class:`~envs.simulation.runs.LoopRun` continued chunk by chunk, the new samples tested by
  :class:`~envs.identification.steady_state.SteadyStateTest`, through
  :func:`~envs.identification.experiment_base.run_until_settled`): the same last sample, outcome and signals up to
  it, on random plants of every family with and without noise, with excursions and small caps,
  diverging runs included; and ``closed_loop_step(..., method="reference")`` against the default;
* a diverging run against :func:`_causal_divergence` (:class:`~envs.simulation.runs.LoopRun` advanced one
  sample at a time under the limit of :func:`~envs.simulation.runs.simulate` for the inputs so far): it
  aborts at the first sample whose state step reaches ``DIVERGENCE_LIMIT`` times the largest input
  so far, whatever the chunks of the reference run, the blocks of noise drawn or the noise after it;
* the recursion of :func:`envs.simulation.runs.simulate` (:func:`envs.simulation._run_kernels._run_one`) against the
  same recursion written as a Python loop.
"""

from __future__ import annotations

import numpy as np
import pytest

from envs.identification.closed_loop_experiment import _loop_sample_time, closed_loop_step
from envs.identification.closed_loop_run import _cumulative_integral, _run_closed_loop
from envs.identification.commissioning import commissioning_pi
from envs.systems.controllers import FPPI, MSP, PID
from envs.identification.experiment_base import MeasurementNoise, excursion_index
from envs.systems.families import FAMILIES, sample_plants
from envs.simulation.loops import closed_loop_of_block, simulation_step
from envs.systems.plants import Plant
from envs.simulation.delay_systems import DIVERGENCE_LIMIT
from envs.simulation.discretization import discretize
from envs.simulation.runs import LoopRun, simulate
from envs.identification.steady_state import window_samples


def _assert_same_run(new, old) -> None:
    assert (new.end, new.settled, new.aborted) == (old.end, old.settled, old.aborted)
    k = old.end + 1
    for field in ("timepts", "control", "output", "true_output"):
        a, b = getattr(new, field)[:k], getattr(old, field)[:k]
        assert a.shape == b.shape and a.tobytes() == b.tobytes(), field


class _DrawnNoise(MeasurementNoise):
    """Given samples, handed out as if drawn as needed (so the run draws them block by block, one
    compiled call per block)."""

    def __init__(self, values: np.ndarray) -> None:
        super().__init__(1.0, values.size, None)
        self._given = values

    @property
    def drawn_as_needed(self) -> bool:
        return True

    def first(self, count: int) -> np.ndarray:
        return self._given[: min(count, self.size)]


def _cases():
    """Random plants of every family under their commissioning PI (or a too aggressive one: 5 of the
    72 runs diverge), with noise, excursion limits and caps."""
    cases = []
    for f, family in enumerate(FAMILIES):
        for i, plant in enumerate(sample_plants(family, 12, 40 + f)):
            pi = commissioning_pi(plant)
            hot = PID(pi.kp * (2.0 + 6.0 * (i % 3)), None if pi.ti is None else pi.ti * (1.0 - 0.3 * (i % 3)))
            controller = hot if i % 4 == 3 else pi
            noise_std = (0.0, 0.01, 0.1)[i % 3]
            limit = (None, 1.05, 1.5, None)[i % 4]
            cap = (60.0, 150.0, 3.0)[i % 3] if i % 5 else 150.0
            cases.append((f"{family}-{i}", plant, controller, noise_std, limit, cap))
    return cases


@pytest.mark.parametrize("name, plant, controller, noise_std, limit, cap", _cases(), ids=lambda v: v if isinstance(v, str) else "")
def test_closed_loop_run_equals_the_reference_run(name, plant, controller, noise_std, limit, cap):
    """Bit for bit ``method="reference"`` (the chunked run), diverging runs included; a diverging run
    aborts at the first sample of :func:`_causal_divergence` (or at an excursion before it).  The
    same run in one compiled call (noise given) and in blocks (noise drawn as needed)."""
    scale = plant.step_time_scale()
    dt = _loop_sample_time(plant, controller.block(), None)
    window = window_samples(scale, dt)
    steps = int(np.ceil(cap * scale / dt)) + 1
    noise = noise_std * np.random.default_rng(len(name)).standard_normal(steps)
    new = _run_closed_loop(plant, controller, 1.0, noise, dt, window, limit)
    _assert_same_run(_run_closed_loop(plant, controller, 1.0, _DrawnNoise(noise), dt, window, limit), new)
    reference = _run_closed_loop(plant, controller, 1.0, noise, dt, window, limit, method="reference")
    _assert_same_run(new, reference)
    assert reference.drive.tobytes() == new.drive.tobytes()
    _assert_same_run(_run_closed_loop(plant, controller, 1.0, _DrawnNoise(noise), dt, window, limit, method="reference"), new)
    if _diverged(new, limit):
        _assert_causal_abort(new, plant, controller, 1.0, noise, dt, limit)
    # the drive the identification uses: the kernel's sums are those of _cumulative_integral
    drive = _cumulative_integral(new.timepts, new.control) if plant.integrating else new.control
    assert new.drive.tobytes() == drive.tobytes()


def _diverged(run, limit) -> bool:
    """Whether ``run`` aborted by a divergence (not by an excursion)."""
    return run.aborted and (limit is None or abs(run.true_output[run.end]) <= limit)


def _causal_divergence(plant, controller, amplitude, noise, dt):
    """``(j, z)``: the first sample ``j`` whose state step diverges (None if none) under the limit of
    :func:`~envs.simulation.runs.simulate` for the inputs up to it (``DIVERGENCE_LIMIT`` times the largest
    so far), by :class:`~envs.simulation.runs.LoopRun` advanced one sample at a time; ``z`` the outputs."""
    system = closed_loop_of_block(plant, controller.block())
    inputs = np.column_stack([np.full(noise.size, amplitude), np.zeros(noise.size), noise])
    run = LoopRun(discretize(system, dt), noise.size)
    for j in range(noise.size):
        sim = run.advance(inputs[: j + 1])
        if sim.diverged:
            return j, sim.outputs
    return None, sim.outputs


def _assert_causal_abort(new, plant, controller, amplitude, noise, dt, limit) -> None:
    """``new`` aborted at the first divergence of :func:`_causal_divergence` or at the first
    excursion before it, with the outputs of the reference up to there."""
    j, z = _causal_divergence(plant, controller, amplitude, noise[: new.end + 2], dt)
    excursion = excursion_index(z[: new.end + 1, 0], limit)
    assert new.aborted and not new.settled
    assert new.end == (j if excursion is None else excursion)
    k = new.end + 1
    assert new.true_output.tobytes() == z[:k, 0].tobytes() and new.control.tobytes() == z[:k, 1].tobytes()
    assert new.output.tobytes() == (z[:k, 0] + noise[:k]).tobytes()


LOOPS = {
    "unstable-pid": (Plant.from_time_constants(2.0, [1.0], 1.0), PID(5.0, 0.5)),
    "unstable-fppi": (Plant(num=[-1.0, 1.0], den=[1.0, 3.0, 3.0, 1.0], dead_time=0.5), FPPI(1.0, 2.5, 1.0, 0.3, 0.3)),
    "unstable-msp": (Plant.from_time_constants(1.0, [1.0], 2.0, integrating=True), MSP(0.3, 3.0, 0.3)),
}


def _divergence(plant, controller, dt, noise):
    """The sample whose state step diverges in the run over ``noise`` (its largest input is the
    set point: the limit is the same for every prefix)."""
    assert np.max(np.abs(noise)) <= 1.0
    system = closed_loop_of_block(plant, controller.block())
    inputs = np.column_stack([np.ones(noise.size), np.zeros(noise.size), noise])
    y = simulate(discretize(system, dt), inputs).outputs[:, 0]
    assert not np.isfinite(y[-1])
    return int(np.argmax(~np.isfinite(y))) - 1


@pytest.mark.parametrize("name", LOOPS)
def test_divergence_aborts_at_the_divergence_whatever_the_chunks(name):
    """The run aborts at the sample whose state step diverges (the last with finite outputs), or at
    an excursion before it: also where the divergence was at the last sample of one of the old
    run's chunks (which aborted at sample 0 then), and wherever the cap ends."""
    plant, controller = LOOPS[name]
    dt = simulation_step(plant, controller, 40)
    noise = 0.01 * np.random.default_rng(2).standard_normal(20000)
    j = _divergence(plant, controller, dt, noise)
    quirk = j // 3 + 1  # the first chunk of 4 windows ends at j with the cap at j + 1 (the run before
    # the compiled one aborted at sample 0 there: it took a divergence at a chunk's last sample for one at its first)
    for window in (quirk, j // 7 + 1, j + 5):
        for steps, limit in ((j + 1, None), (j + 2, None), (j + 1, 1.5), (j + 2, 1.5), (20000, None)):
            args = (plant, controller, 1.0, noise[:steps], dt, window, limit)
            new = _run_closed_loop(*args)
            _assert_same_run(new, _run_closed_loop(*args, method="reference"))
            _assert_causal_abort(new, plant, controller, 1.0, noise[:steps], dt, limit)
            assert new.end == (j if limit is None else min(j, excursion_index(new.true_output, limit)))
            assert np.isfinite(new.true_output).all()


@pytest.mark.parametrize("name", LOOPS)
@pytest.mark.parametrize("spike", [0.5, 3.0, 50.0, 1e6])
def test_divergence_limit_is_that_of_the_inputs_so_far(name, spike):
    """A large noise sample raises the limit from its sample on: after the divergence it changes
    nothing (the limit is causal, whatever the blocks of noise drawn); before it, the run aborts at
    the first sample that reaches the limit of the inputs so far (:func:`_causal_divergence`)."""
    plant, controller = LOOPS[name]
    dt = simulation_step(plant, controller, 40)
    noise = 0.01 * np.random.default_rng(3).standard_normal(20000)
    j = _divergence(plant, controller, dt, noise)
    for window in (j // 6 + 1, j // 20 + 1):  # j in the first block of noise drawn or a later one
        for at in (j + 1, j + 5 * window, j - window, j // 2, 0):
            spiky = noise.copy()
            spiky[at] = spike
            args, rest = (plant, controller, 1.0), (dt, window, None)
            new = _run_closed_loop(*args, _DrawnNoise(spiky), *rest)
            given = _run_closed_loop(*args, spiky, *rest)  # one call: the same run
            _assert_same_run(new, given)
            _assert_same_run(new, _run_closed_loop(*args, _DrawnNoise(spiky), *rest, method="reference"))
            if new.aborted:
                _assert_causal_abort(new, plant, controller, 1.0, spiky, dt, None)
            else:  # a large spike before the divergence raised the limit: no divergence up to the end
                assert spike == 1e6 and at < j
                k, z = _causal_divergence(plant, controller, 1.0, spiky[: new.end + 1], dt)
                assert k is None and new.true_output.tobytes() == z[:, 0].tobytes()
            if at > j:  # the noise after the divergence changes neither the run nor its limit
                assert new.end == j


def _recursion_reference(discrete, inputs):
    """The recursion of :class:`~envs.simulation.discretization.DiscreteDelaySystem` as a Python loop, every sum in
    the order of the compiled one (over the state, the inputs, then the delayed signals)."""
    s = discrete.system
    n, nv, steps = s.n_states, s.delays.size, inputs.shape[0]
    whole, a = discrete.whole_samples, discrete.fraction / discrete.dt
    R = discrete.R.reshape(n, 3 * nv)
    limit = DIVERGENCE_LIMIT * max(1.0, float(np.max(np.abs(inputs))))
    w = np.zeros((steps + 1, nv))  # w[j] of sample j; w[j] = 0 for j < 0
    z = np.full((steps, s.n_outputs), np.nan)
    x = [0.0] * n

    def past(i, j):
        return float(w[j, i]) if j >= 0 else 0.0

    def affine(row_x, row_d, row_v, d, v):
        acc = 0.0
        for c in range(n):
            acc += float(row_x[c]) * x[c]
        for c in range(d.size):
            acc += float(row_d[c]) * float(d[c])
        for c in range(len(v)):
            acc += float(row_v[c]) * v[c]
        return acc

    for j in range(steps):
        d = inputs[j]
        v = [a[i] * past(i, j - whole[i] - 1) + (1.0 - a[i]) * past(i, j - whole[i]) for i in range(nv)]
        for o in range(s.n_outputs):
            z[j, o] = affine(s.C1[o], s.D11[o], s.D12[o], d, v)
        for i in range(nv):
            w[j, i] = affine(s.C2[i], s.D21[i], s.D22[i], d, v)
        window = [past(i, j - whole[i] - 1 + k) for i in range(nv) for k in range(3)]
        x = [affine(discrete.Phi[r], discrete.Gamma[r], R[r], d, window) for r in range(n)]
        if not all(abs(value) < limit for value in x):
            break
    return z


@pytest.mark.parametrize("name", ["stable-pi", "fppi", "msp", *LOOPS])
def test_compiled_recursion_matches_the_python_loop(name):
    loops = {
        **LOOPS,
        "stable-pi": (Plant.from_time_constants(1.0, [1.0, 0.4], 0.73), PID(0.6, 1.4, 0.2, 8.0)),
        "fppi": (Plant.from_time_constants(2.0, [1.0], 0.5), FPPI(2.0, 1.0, 0.5, 1.0, 1.0)),
        "msp": (Plant.from_time_constants(1.0, [0.5], 1.3, integrating=True), MSP(1.0, 1.3, 2.0, True)),
    }
    plant, controller = loops[name]
    system = closed_loop_of_block(plant, controller.block())
    discrete = discretize(system, simulation_step(plant, controller, 30))
    rng = np.random.default_rng(9)
    inputs = np.column_stack([np.ones(700), np.where(np.arange(700) > 300, 0.5, 0.0), 0.05 * rng.standard_normal(700)])
    z = simulate(discrete, inputs).outputs
    reference = _recursion_reference(discrete, inputs)
    assert z.tobytes() == reference.tobytes()


@pytest.mark.parametrize("family", FAMILIES)
def test_closed_loop_step_reference_method_equals_compiled(family):
    """The public choice: ``closed_loop_step(..., method="reference")`` gives the same result, every
    signal and identified number bit for bit, with noise drawn from the same seed."""
    for plant in sample_plants(family, 3, 90):
        for limit in (None, 1.05):
            args = dict(noise_std=0.02, excursion_limit=limit)
            fast = closed_loop_step(plant, np.random.default_rng(4), **args)
            reference = closed_loop_step(plant, np.random.default_rng(4), **args, method="reference")
            for field in fast.__dataclass_fields__:
                a, b = getattr(fast, field), getattr(reference, field)
                if isinstance(a, np.ndarray):
                    assert a.tobytes() == b.tobytes(), field
                else:
                    assert repr(a) == repr(b), field


def test_closed_loop_step_refuses_unknown_method():
    plant = Plant.from_time_constants(1.0, [1.0], 0.5)
    with pytest.raises(ValueError, match="method must be 'compiled' or 'reference', got 'chunked'"):
        closed_loop_step(plant, np.random.default_rng(0), method="chunked")
