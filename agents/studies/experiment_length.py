"""Why the fixed procedure takes less experiment time as noise grows, and whether it should not.

For each of the 80 FPPI-v0 test plants (``plant_set("stable", "test", 80)``, plant i with
``numpy.random.default_rng(i)``, as ``identify`` draws its noise) and each noise level: the fixed
procedure with the library's stopping rule ("detected", checked equal to ``identify``), and the SAME
noisy runs (the same noise samples, continued) cut later: k more windows of ``T_ar`` after each
experiment's stop, at the stop of the noise-free run, or the closed-loop step only extended.
Prints identification errors against the noise-free procedure, ``T_f_bar/T_n`` (eq. 22), and the
mean costs of ``fppi-eq34`` and of the oracle on the identified model (``design``: without the
``0.01 t_exp/T_ar`` term).  Reads private run helpers of the experiments (a tool, not an API).

Usage: deadtime study experiment-length 0.01,0.05,0.1,0.2 [OUT.json, default experiment_length.json] "detected,+4 T_ar,..."
(the third argument: the policies whose oracle is computed, about 1 s a plant).  Results: docs/numerics.md,
"Experiment length and noise"."""
from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from envs.systems.plant_sets import plant_set
from envs.identification import closed_loop_experiment as cle, open_loop_step as ole
from envs.identification.experiment_base import measurement_noise, cap_steps, MeasurementNoise, record_fields, ExperimentRun, sample_time, snap_to_integer
from envs.identification.commissioning import commissioning_pi
from envs.identification.steady_state import window_samples
from envs.identification.procedure import identify, Identification
from envs.simulation.open_loop import open_loop_response
from envs.analysis.scoring import score, Constraints, CostWeights
from baselines.oracle import oracle
from baselines.rules.registry import RuleInputs, get_rule

RULE = get_rule("fppi-eq34")

def closed_runs(plant, rng, noise_std):
    controller = commissioning_pi(plant)
    scale = plant.step_time_scale()
    block = controller.block()
    dt = cle._loop_sample_time(plant, block, None)
    cap = cap_steps(scale, dt, None)
    noise = measurement_noise(rng, noise_std, cap)
    window = window_samples(scale, dt)
    detected = cle._run_closed_loop(plant, controller, 1.0, noise, dt, window, None, block=block)
    total = min(detected.end + 1 + 8 * window + 1, cap)
    long = cle._run_closed_loop(plant, controller, 1.0, MeasurementNoise.given(noise.first(total)), dt, total + 10, None, block=block)
    assert np.array_equal(long.output[: detected.end + 1], detected.output[: detected.end + 1]), "extended run differs"
    def at(end):
        k = min(end, long.end) + 1
        run = cle._ClosedLoopRun(long.timepts[:k], long.control[:k], long.output[:k], long.true_output[:k], k - 1, True, False, long.drive[:k])
        return cle._identify_closed_loop(plant, controller, 1.0, run, window, scale)
    return detected.end, window, at

def open_runs(plant, rng, noise_std, first):
    height, tar, gain = 1.0 / first.gain, first.residence_time, first.gain
    dt, scale = sample_time(plant, None), plant.step_time_scale()
    steps = cap_steps(scale, dt, None, minimum=2.0 * tar)
    noise = measurement_noise(rng, noise_std, steps)
    window = window_samples(tar, dt)
    start = math.ceil(snap_to_integer(2.0 * tar / dt))
    detected = ole._run_to_steady_state(plant, np.full(steps, height), noise, dt, window, start, None)
    total = min(detected.end + 1 + 8 * window + 1, steps)
    y = open_loop_response(plant.state_space(), plant.dead_time, np.full(total, height), dt)
    measured = y + noise.first(total)
    assert np.allclose(measured[: detected.end + 1], detected.output[: detected.end + 1], rtol=0, atol=1e-12)
    def at(end):
        k = min(end, total - 1) + 1
        run = ExperimentRun(np.arange(k) * dt, np.full(k, height), measured[:k], y[:k], k - 1, True, False)
        record = record_fields(run, scale)
        fields = ole._step_identification(record, height, tar, gain, window, True)
        return ole.OpenLoopStepResult(**record, height=height, settled=True, **fields)
    return detected.end, window, at

def procedure(plant, seed, noise_std, policy, clean=None):
    rng = np.random.default_rng(seed)
    end1, w1, closed_at = closed_runs(plant, rng, noise_std)
    first = closed_at(policy(end1, w1, 0, clean))
    end2, w2, open_at = open_runs(plant, rng, noise_std, first)
    second = open_at(policy(end2, w2, 1, clean))
    return Identification(False, first.gain, first.residence_time, second.model, first.sopdt, None, second.mismatch_time,
                          math.nan, first.duration + second.duration, first, second), (end1, end2)

def cost(plant, ident):
    s = score(plant, RULE(RuleInputs.from_identification(ident)), experiment_time=ident.experiment_time)
    return s.cost, s.cost - s.experiment_cost


def experiment_length(noises: list[float], out: str | Path = "experiment_length.json", oracle_policies: set[str] = frozenset()) -> None:
    """Play every policy at every noise level on the 80 plants, write the rows to ``out`` (JSON) and print
    the means per noise and policy; the oracle's cost only for ``oracle_policies``."""
    plants = plant_set("stable", "test", 80)
    policies = {"detected": lambda end, w, j, clean: end}
    for k in (1, 2, 4):
        policies[f"+{k} T_ar"] = (lambda k: lambda end, w, j, clean: end + k * w)(k)
    policies["noise-free length"] = lambda end, w, j, clean: max(end, clean[j])
    for k in (2, 4):
        policies[f"closed +{k} T_ar only"] = (lambda k: lambda end, w, j, clean: end + k * w if j == 0 else end)(k)
    policies["closed noise-free length only"] = lambda end, w, j, clean: max(end, clean[j]) if j == 0 else end
    rows = []
    for i, plant in enumerate(plants):
        ref, clean_ends = procedure(plant, i, 0.0, policies["detected"])
        check = identify(plant, np.random.default_rng(i), 0.0)
        assert check.gain == ref.gain and check.residence_time == ref.residence_time and check.mismatch_time == ref.mismatch_time
        for noise in noises:
            lib = identify(plant, np.random.default_rng(i), noise)
            for name, policy in policies.items():
                ident, ends = procedure(plant, i, noise, policy, clean_ends)
                if name == "detected":
                    assert ident.gain == lib.gain and ident.residence_time == lib.residence_time and ident.mismatch_time == lib.mismatch_time
                total, design = cost(plant, ident)
                best = oracle(plant, ident, "fppi").cost if name in oracle_policies else math.nan
                rows.append(dict(oracle=best, plant=i, noise=noise, policy=name, time=ident.experiment_time / plant.residence_time,
                                 gain=ident.gain / ref.gain - 1, tar=ident.residence_time / ref.residence_time - 1,
                                 tn=ident.fopdt.time_constant / ref.fopdt.time_constant - 1,
                                 tf=ident.mismatch_time / ref.fopdt.time_constant, tf_ref=ref.mismatch_time / ref.fopdt.time_constant,
                                 cost=total, design_cost=design))
    Path(out).write_text(json.dumps(rows))
    for noise in noises:
        for name in policies:
            r = [x for x in rows if x["noise"] == noise and x["policy"] == name]
            a = lambda key: np.array([x[key] for x in r])
            rms = lambda key: float(np.sqrt(np.mean(a(key) ** 2)))
            print(f"noise {noise:4.2f} {name:18s} t_exp {a('time').mean():6.2f} T_ar | K bias {a('gain').mean():+.4f} rms {rms('gain'):.4f} | T_ar bias {a('tar').mean():+.4f} rms {rms('tar'):.4f} | "
                  f"T_n bias {a('tn').mean():+.4f} rms {rms('tn'):.4f} | T_f/T_n {a('tf').mean():.4f} (noise-free {a('tf_ref').mean():.4f}) | eq34 cost {a('cost').mean():.3f} design {a('design_cost').mean():.3f} | oracle {a('oracle').mean():.3f}")
