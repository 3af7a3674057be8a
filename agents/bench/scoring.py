"""``deadtime bench``, part one: the scoring of designed loops, its speed and its accuracy.

The loops: ``per_family`` plants of each of the families ``fopdt``, ``sopdt``, ``lag-chain`` and
``integrating`` (:func:`envs.systems.families.sample_plants` with the bench's seed), each identified by the
fixed procedure (noise free, :func:`envs.identification.procedure.identify`) and given a design of
:func:`baselines.oracle.design`: the stable plants alternately a Gorez-Klan PID (``mu = 2``) and an
FPPI (``T_r = 0.5 T_n``), the integrating plants an MSP (``T_r = 2.5 L_n``); a parameter that
breaks the default constraints is raised by half until the design is feasible, so that every
scoring includes both simulations.  The same loops go to our scoring, to the python-control
reference (:mod:`agents.bench.reference`) and to the fine-step reference (:mod:`agents.bench.fine_step`).

Every timed pass is warm: our kernels are compiled, and the references have run once untimed (the
first pass of the python-control way imports its modules: about 0.9 s of its 2.4 s on the 20 loops
here, which, counted, would make the speed-up about 1.7x too large).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Loop", "bench_loops", "measure_rate", "scoring_figures"]

FAMILIES = ("fopdt", "sopdt", "lag-chain", "integrating")
TYPICAL_PARAMETER = {"pid": 2.0, "fppi": 0.5, "msp": 2.5}  # mu, T_r/T_n, T_r/L_n
FEASIBILITY_STEPS = 8


@dataclass(frozen=True)
class Loop:
    """One benchmark loop: the true plant and the controller designed from its identification."""

    family: str
    structure: str
    relative_parameter: float
    plant: Any
    controller: Any


def bench_loops(per_family: int, seed: int) -> list[Loop]:
    """The benchmark loops (see the module docstring)."""
    from baselines.oracle import design, relative_scale
    from envs.structures import STRUCTURES
    from envs.systems.families import sample_plants
    from envs.identification.procedure import identify
    from envs.analysis.scoring import score

    loops = []
    for family in FAMILIES:
        for i, plant in enumerate(sample_plants(family, per_family, seed)):
            identification = identify(plant, np.random.default_rng([seed, i]))
            if family == "integrating":
                structure = "msp"
            else:
                structure = "pid" if i % 2 == 0 and identification.sopdt.dead_time > 0 else "fppi"
            model = STRUCTURES[structure].model_of(identification)
            relative = TYPICAL_PARAMETER[structure]
            for _ in range(FEASIBILITY_STEPS):
                controller = design(structure, model, relative * relative_scale(structure, model))
                if score(plant, controller).feasible:
                    break
                relative *= 1.5
            loops.append(Loop(family, structure, relative, plant, controller))
    return loops


def measure_rate(function: Callable[[], Any], items: int, min_time: float, max_repeats: int = 1000) -> float:
    """``items`` per second of ``function()``, repeated until at least ``min_time`` seconds have passed."""
    repeats, start = 0, time.perf_counter()
    while True:
        function()
        repeats += 1
        elapsed = time.perf_counter() - start
        if elapsed >= min_time or repeats >= max_repeats:
            return repeats * items / elapsed


def _batched_scoring(plants: list, controllers: list) -> Callable[[], Any]:
    """A batched scoring if :mod:`envs.analysis.scoring` has one, else batched IAE and per-loop robustness."""
    import envs.analysis.scoring

    batch = getattr(envs.analysis.scoring, "score_batch", None)
    if batch is not None:
        return lambda: batch(plants, controllers)
    from envs.analysis.loop_analysis import plant_margins
    from envs.analysis.performance import iae_batch

    def fallback() -> None:
        for plant, controller in zip(plants, controllers):
            plant_margins(plant, controller)
        iae_batch(plants, controllers)

    return fallback


def _relative_error(value: float, reference: float) -> float:
    if value == reference:
        return 0.0
    if not (math.isfinite(value) and math.isfinite(reference)):
        return math.inf
    return abs(value / reference - 1)


def scoring_figures(
    loops: list[Loop], *, min_time: float, pade_order: int, samples_per_time_scale: int,
    progress: Callable[[str], None] = lambda message: None, rounds: int = 1,
) -> dict[str, Any]:
    """Speed and accuracy of our scoring and of the python-control reference on ``loops``; the
    speed-up is the median over ``rounds`` rounds, each our scoring (``min_time/rounds``) then one
    reference pass over the loops (a shared machine's speed drifts between measurements)."""
    import envs.analysis.scoring
    from agents.bench.fine_step import STEPS_PER_TIME_SCALE, fine_step_iae
    from agents.bench.reference import reference_iae, reference_score
    from envs.analysis.loop_analysis import plant_margins
    from envs.analysis.performance import iae, iae_batch
    from envs.analysis.scoring import score

    plants = [loop.plant for loop in loops]
    controllers = [loop.controller for loop in loops]
    n = len(loops)
    progress("warm-up (numba compilation)")
    ours = [score(p, c) for p, c in zip(plants, controllers)]
    if not all(s.feasible and not s.iae_lower_bound for s in ours):
        raise ValueError("a benchmark loop is infeasible or capped: its scoring would skip or stop the simulations")

    def each(function: Callable[[Any, Any], Any]) -> Callable[[], None]:
        return lambda: [function(p, c) for p, c in zip(plants, controllers)]

    progress(f"our scoring one loop at a time, and the python-control reference (Pade order {pade_order}, "
             f"T/{samples_per_time_scale}): {rounds} rounds of each")
    options = {"pade_order": pade_order, "samples_per_time_scale": samples_per_time_scale}
    ours_rates, reference_rates, reference = [], [], []
    with warnings.catch_warnings():  # overflow in python-control's step loop of a badly conditioned model
        warnings.simplefilter("ignore", RuntimeWarning)
        # warm-up, untimed: the first pass imports python-control's and scipy.signal's modules (module docstring)
        reference = [reference_score(p, c, **options) for p, c in zip(plants, controllers)]
        for _ in range(rounds):  # interleaved: the speed-up of each round compares one machine state
            ours_rates.append(measure_rate(each(score), n, min_time / rounds))
            start = time.perf_counter()
            reference = [reference_score(p, c, **options) for p, c in zip(plants, controllers)]
            reference_rates.append(n / (time.perf_counter() - start))
    figures: dict[str, Any] = {
        "scorings_per_s_single": float(np.median(ours_rates)),
        "scorings_per_s_python_control": float(np.median(reference_rates)),
        "speedup_vs_python_control": float(np.median(np.divide(ours_rates, reference_rates))),
        "speedup_rounds": [a / b for a, b in zip(ours_rates, reference_rates)],
    }
    progress("our scoring, batched")
    figures["scorings_per_s_batched"] = measure_rate(_batched_scoring(plants, controllers), n, min_time)
    figures["speedup_batched_vs_python_control"] = figures["scorings_per_s_batched"] / figures["scorings_per_s_python_control"]
    figures["batched_method"] = (
        "envs.analysis.scoring.score_batch" if hasattr(envs.analysis.scoring, "score_batch")
        else "envs.analysis.performance.iae_batch + envs.analysis.loop_analysis.plant_margins per loop (no batched score API)"
    )
    progress("our robustness and IAE apart")
    figures["margins_per_s"] = measure_rate(each(plant_margins), n, min_time)
    figures["iae_per_s_single"] = measure_rate(each(iae), n, min_time)
    figures["iae_per_s_batched"] = measure_rate(lambda: iae_batch(plants, controllers), n, min_time)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        progress("IAE alone: python-control forced_response and scipy.signal.dlsim")
        for method in ("python_control", "scipy_dlsim"):
            reference_iae(plants[0], controllers[0], method=method, **options)  # warm-up, untimed (imports)
            start = time.perf_counter()
            for p, c in zip(plants, controllers):
                reference_iae(p, c, method=method, **options)
            figures[f"iae_per_s_{method}"] = n / (time.perf_counter() - start)
    figures["pade_order"] = pade_order
    figures["python_control_step"] = f"T/{samples_per_time_scale}"
    figures["our_step"] = "T_ar/50 (exact ZOH, exact fractional dead time)"

    progress(f"fine-step reference (RK4, T/{STEPS_PER_TIME_SCALE})")
    fine = [fine_step_iae(p, c) for p, c in zip(plants, controllers)]
    errors_ours, errors_reference = [], []
    for o, r, f in zip(ours, reference, fine):
        errors_ours.append(max(_relative_error(o.iae_load, f.load), _relative_error(o.iae_setpoint, f.setpoint)))
        errors_reference.append(max(_relative_error(r.iae_load, f.load), _relative_error(r.iae_setpoint, f.setpoint)))
    figures["accuracy_ours"] = max(errors_ours)
    figures["accuracy_python_control"] = max(errors_reference)
    figures["accuracy_ours_median"] = float(np.median(errors_ours))
    figures["accuracy_python_control_median"] = float(np.median(errors_reference))
    figures["accuracy_reference"] = f"RK4 with a cubic-interpolated delay buffer, step T/{STEPS_PER_TIME_SCALE}"
    figures["margin_agreement"] = max(
        max(_relative_error(getattr(r, name), getattr(o, name)) if math.isfinite(getattr(o, name)) else 0.0
            for name in ("ms", "gain_margin", "phase_margin_deg", "delay_margin"))
        for o, r in zip(ours, reference)
    )  # fmt: skip
    return figures
