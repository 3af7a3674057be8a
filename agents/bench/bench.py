"""The speed and accuracy of the scoring and the environments, in one run (``deadtime bench``, whose
command line is :mod:`agents.commands.bench`).

Four parts, each on the same machine state:

1. Scoring (:mod:`agents.bench.scoring`): our :func:`envs.analysis.scoring.score` on designed loops of four
   plant families, one loop at a time and batched, against the same figures computed the
   python-control way (:mod:`agents.bench.reference`, Padé dead times); the accuracy of both is
   the largest relative IAE error against an independent fine-step simulation
   (:mod:`agents.bench.fine_step`).  This part runs pinned to one CPU (``os.sched_setaffinity``);
   the speed-up is the median over :data:`SCORING_ROUNDS` rounds of ours then python-control.
2. Environments (:mod:`agents.bench.episodes`): episodes per second of ``DeadTime/PID-v0``, single
   and vectorized (2 copies), in both modes, with and without the oracle.
3. The native vector environment (:mod:`agents.bench.vector`, pinned to one CPU): the
   compiled-arithmetic floor of a fixed-mode episode (:mod:`agents.bench.floor`: the time inside its
   compiled calls, measured) for the single environment and the native vector environment with 32
   slots, the ratio of each one's measured episode time to its floor, and episodes per second of
   the single environment and of the native one with 1, 8 and 32 slots; and the lower bound of a
   bit-identical episode (the floor with the library calls a batch giving the same bytes would
   keep, :func:`agents.bench.floor.compiled_calls_timed`; timed in single and in native x32
   episodes, the lower of the two), with the largest ratio of episodes/s native x32 over single
   that it allows.  Measured in :data:`VECTOR_ROUNDS` rounds of every setting; each figure is the
   median over the rounds of its value in one round.
4. Labels (:mod:`agents.bench.labels`, pinned to one CPU): training labels per second (a reset and the
   oracle's action, as a learned-rule fit computes them) by the oracle's reference search and by its
   fast search (:mod:`baselines.fast_search`) on the same plants, and their ratio.
5. Training: the share of ``learn`` spent inside the environment, for PPO (``configs/ppo.yaml``, one
   environment) and for SAC (``configs/sac.yaml``, the agent of the demo); and PPO's samples per
   second of ``learn`` (``configs/ppo.yaml``, one rollout of 128 steps per environment and its
   update) with 1, 8 and 32 slots of the native vector environment, with the environment's share.

Every part runs in a child process whose BLAS, OpenMP and numba pools have one thread
(:data:`agents.runtime.THREAD_VARIABLES`; the variables must be set before numpy is imported): on this 2-core
machine under load, OpenBLAS's default two threads made ``scipy.linalg.expm`` of the small matrices
of the discretizations up to ten times slower.  Vectorized workers inherit the setting.

``--json`` prints one object with every figure (see :data:`HEADLINE` for the main ones; those of a
skipped part are null); progress goes to standard error.  Rates are wall-clock figures of this machine at this moment: the JSON
records the commit, whether ``envs/`` had uncommitted changes, the CPU count and the load.
"""

from __future__ import annotations

import os
import platform
import statistics
import sys
import time
from typing import Any

from agents.runtime import REPO, THREAD_VARIABLES, git, versions

__all__ = ["HEADLINE", "bench", "format_table", "machine_info"]

HEADLINE = (
    "scorings_per_s_single",
    "scorings_per_s_batched",
    "speedup_vs_python_control",
    "accuracy_ours",
    "accuracy_python_control",
    "episodes_per_s_fixed",
    "episodes_per_s_agent",
    "env_share_of_ppo_time",
    "episode_floor_ms",
    "episode_to_floor_single",
    "episode_to_floor_native32",
    "native32_vs_single",
    "native32_vs_single_bound",
    "ppo_samples_per_s_native32_vs_1",
    "labels_per_s_reference",
    "labels_per_s_fast",
    "labels_fast_vs_reference",
)
ENV_ID = "DeadTime/PID-v0"
SEED = 0
N_ENVS = 2
NATIVE_SLOTS = (1, 8, 32)
FLOOR_EPISODES = 64
VECTOR_ROUNDS = 5
"""The vector part measures in rounds, each of every setting, and reports the median over them: the
speed of a shared 2-core machine drifts by up to 2x within minutes, so settings measured one
after the other in one block would compare different machine states."""
VECTOR_SECONDS = 6.0  # per setting, over all rounds
SCORING_ROUNDS = 3  # our scoring and python-control, interleaved (the speed-up: median over rounds)
PPO_ROUNDS = 3  # the PPO figures too, each a median over rounds of x1, x8, x32
LABEL_PLANTS = 40
LABEL_ROUNDS = 3


def _progress(message: str) -> None:
    print(f"[bench {time.strftime('%H:%M:%S')}] {message}", file=sys.stderr, flush=True)


def machine_info() -> dict[str, Any]:
    """CPU count, load, versions, commit."""
    packages = ("numpy", "scipy", "numba", "control", "gymnasium", "stable_baselines3", "torch")
    package_versions = {k: v for k, v in versions(packages, missing=None).items() if k != "python"}
    status = git("status", "--porcelain", "--", "envs", "baselines")
    return {
        "cpu_count": os.cpu_count(),
        "load_average": list(os.getloadavg()),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "python": platform.python_version(),
        "versions": package_versions,
        "commit": git("rev-parse", "--short", "HEAD"),
        "envs_uncommitted_changes": bool(status) if status is not None else None,
        "thread_variables": {name: os.environ.get(name) for name in THREAD_VARIABLES},
    }


def _one_core() -> tuple[set[int] | None, list[int] | None]:
    """Pin this process to one CPU; returns the previous affinity (to restore) and the new one."""
    if not hasattr(os, "sched_setaffinity"):
        return None, None
    previous = os.sched_getaffinity(0)
    core = min(previous)
    os.sched_setaffinity(0, {core})
    return previous, [core]


def _scoring_part(quick: bool, pade_order: int | None, samples: int | None) -> dict[str, Any]:
    from agents.bench.reference import PADE_ORDER, SAMPLES_PER_TIME_SCALE
    from agents.bench.scoring import bench_loops, scoring_figures

    previous, core = _one_core()
    try:
        _progress("building the benchmark loops (identification and designs)")
        loops = bench_loops(1 if quick else 5, SEED)
        figures = scoring_figures(
            loops,
            min_time=0.3 if quick else 2.0,
            pade_order=pade_order or PADE_ORDER,
            samples_per_time_scale=samples or SAMPLES_PER_TIME_SCALE,
            progress=_progress,
            rounds=1 if quick else SCORING_ROUNDS,
        )
    finally:
        if previous is not None:
            os.sched_setaffinity(0, previous)
    figures["loops"] = len(loops)
    figures["loop_structures"] = {s: sum(loop.structure == s for loop in loops) for s in ("pid", "fppi", "msp")}
    figures["scoring_cpu_affinity"] = core
    return figures


def _min_episodes(quick: bool, oracle: bool) -> int:
    """Episodes per measurement: agent-mode episodes vary a lot in cost, oracle episodes are long."""
    return 1 if quick else (4 if oracle else 16)


def _env_part(quick: bool) -> dict[str, Any]:
    from agents.bench.episodes import episodes_per_s, vector_episodes_per_s

    min_time = 0.0 if quick else 3.0
    rates: dict[str, float] = {}
    for mode in ("fixed", "agent"):
        for oracle in (False, True):
            name = f"single/{mode}" + ("/oracle" if oracle else "")
            _progress(f"episodes: {name}")
            rates[name] = episodes_per_s(ENV_ID, mode, oracle, min_time, SEED, _min_episodes(quick, oracle))
    kinds = ("dummy",) if quick else ("sync", "dummy", "subproc")
    for kind in kinds:
        for mode in ("fixed",) if quick else ("fixed", "agent"):
            for oracle in (False,) if quick else (False, True):
                name = f"{kind}{N_ENVS}/{mode}" + ("/oracle" if oracle else "")
                _progress(f"episodes: {name}")
                rates[name] = vector_episodes_per_s(
                    kind, ENV_ID, mode, oracle, N_ENVS, min_time, SEED, _min_episodes(quick, oracle)
                )
    return {
        "episodes_per_s_fixed": rates["single/fixed"],
        "episodes_per_s_agent": rates["single/agent"],
        "episodes_per_s_fixed_oracle": rates["single/fixed/oracle"],
        "episodes_per_s_agent_oracle": rates["single/agent/oracle"],
        "episodes_per_s": rates,
        "env_id": ENV_ID,
    }


def _vector_round(min_time: float, episodes: int, quick: bool, warm: bool) -> dict[str, Any]:
    """One round of the vector part: the floors (compiled, single and native x32; the bit-identical
    bound, in single and in native x32 episodes), then the episodes per second of the single
    environment and of the native one."""
    from agents.bench.episodes import episodes_per_s
    from agents.bench.vector import episode_floor, native_episodes_per_s

    last = NATIVE_SLOTS[-1]
    floors = {"single": episode_floor(ENV_ID, None, episodes, SEED, warm=warm),
              f"native{last}": episode_floor(ENV_ID, last, episodes, SEED, warm=warm),
              "library": episode_floor(ENV_ID, None, episodes, SEED, library=True, warm=True),
              f"library{last}": episode_floor(ENV_ID, last, episodes, SEED, library=True, warm=True)}
    rates = {"single": episodes_per_s(ENV_ID, "fixed", False, min_time, SEED, 1 if quick else 64)}
    for n in NATIVE_SLOTS:
        rates[f"native{n}"] = native_episodes_per_s(ENV_ID, n, min_time, SEED, n if quick else max(64, 4 * n))
    return {"floors": floors, "rates": rates}


def _median(values: list[float]) -> float:
    return float(statistics.median(values))


def _vector_part(quick: bool) -> dict[str, Any]:
    previous, core = _one_core()
    rounds = 1 if quick else VECTOR_ROUNDS
    min_time, episodes = (0.0, 32) if quick else (VECTOR_SECONDS / rounds, FLOOR_EPISODES)
    try:
        measured = []
        for r in range(rounds):
            _progress(f"native vector environment, round {r + 1}/{rounds}: floors of {episodes} episodes, then "
                      f"episodes/s of the single and native environments (one core)")
            measured.append(_vector_round(min_time, episodes, quick, warm=r > 0))
    finally:
        if previous is not None:
            os.sched_setaffinity(0, previous)
    last = f"native{NATIVE_SLOTS[-1]}"
    library = f"library{NATIVE_SLOTS[-1]}"

    def bound(floors: dict) -> float:  # the lower of the two bounds (the same calls cost less one plant at a time)
        return min(floors["library"]["seconds"], floors[library]["seconds"])

    def per_round(figure) -> float:  # the median over the rounds of a figure of one round's numbers
        return _median([figure(m["floors"], m["rates"]) for m in measured])

    top = measured[-1]["floors"]
    return {
        "vector_rounds": rounds,
        "episode_floor_ms": per_round(lambda f, r: 1e3 * f["single"]["seconds"]),
        "episode_floor_calls": top["single"]["calls"],
        "episode_floor_top_ms": {k: 1e3 * v for k, v in top["single"]["top"].items()},
        "episode_floor_native32_ms": per_round(lambda f, r: 1e3 * f[last]["seconds"]),
        "episode_bound_ms": per_round(lambda f, r: 1e3 * bound(f)),
        "episode_bound_single_ms": per_round(lambda f, r: 1e3 * f["library"]["seconds"]),
        "episode_bound_native32_ms": per_round(lambda f, r: 1e3 * f[library]["seconds"]),
        "episode_bound_top_ms": {k: 1e3 * v for k, v in top["library"]["top"].items()},
        "episode_ms_single": per_round(lambda f, r: 1e3 / r["single"]),
        "episode_ms_native32": per_round(lambda f, r: 1e3 / r[last]),
        "episode_to_floor_single": per_round(lambda f, r: 1.0 / (r["single"] * f["single"]["seconds"])),
        "episode_to_floor_native32": per_round(lambda f, r: 1.0 / (r[last] * f[last]["seconds"])),
        "episodes_per_s_native": {name: _median([m["rates"][name] for m in measured]) for name in measured[0]["rates"]},
        "native32_vs_single": per_round(lambda f, r: r[last] / r["single"]),
        "native32_vs_single_rounds": [m["rates"][last] / m["rates"]["single"] for m in measured],
        "native32_vs_single_bound": per_round(lambda f, r: 1.0 / (r["single"] * bound(f))),
        "vector_cpu_affinity": core,
    }


def _labels_part(quick: bool) -> dict[str, Any]:
    from agents.bench.labels import label_figures

    previous, core = _one_core()
    try:
        figures = label_figures(2 if quick else LABEL_PLANTS, 1 if quick else LABEL_ROUNDS, _progress)
    finally:
        if previous is not None:
            os.sched_setaffinity(0, previous)
    figures["labels_cpu_affinity"] = core
    return figures


def _ppo_native_part(quick: bool) -> dict[str, Any]:
    from agents.bench.vector import ppo_throughput

    n_steps = 16 if quick else 128
    rounds = 1 if quick else PPO_ROUNDS
    measured: list[dict[str, float]] = []
    for r in range(rounds):
        one: dict[str, float] = {}
        for n in NATIVE_SLOTS:
            _progress(f"PPO (configs/ppo.yaml), native x{n}, round {r + 1}/{rounds}: one rollout of {n_steps} steps "
                      f"per environment and its update")
            result = ppo_throughput(str(REPO / "configs" / "ppo.yaml"), ENV_ID, n, n_steps)
            one[f"ppo_samples_per_s_native{n}"] = result["samples_per_s"]
            one[f"env_share_of_ppo_native{n}"] = result["share"]
        one["ppo_samples_per_s_native32_vs_1"] = one["ppo_samples_per_s_native32"] / one["ppo_samples_per_s_native1"]
        measured.append(one)
    figures = {key: _median([one[key] for one in measured]) for key in measured[0]}
    figures["ppo_rounds"] = rounds
    return figures


def _training_part(quick: bool) -> dict[str, Any]:
    from agents.bench.episodes import training_env_share

    root = REPO / "configs"
    n_steps = 16 if quick else 128
    _progress(f"PPO (configs/ppo.yaml): one rollout of {n_steps} steps and one update")
    ppo = training_env_share(str(root / "ppo.yaml"), ENV_ID, n_steps, (f"hyperparameters.n_steps={n_steps}",))
    starts, sac_steps = (16, 16) if quick else (256, 256)
    _progress(f"SAC (configs/sac.yaml): {sac_steps} steps after {starts} random ones")
    sac = training_env_share(str(root / "sac.yaml"), ENV_ID, sac_steps, (f"hyperparameters.learning_starts={starts}",),
                             warmup_steps=starts)  # fmt: skip
    return {
        "env_share_of_ppo_time": ppo["share"], "ppo_learn_seconds": ppo["learn_seconds"],
        "ppo_env_seconds": ppo["env_seconds"], "ppo_timesteps": ppo["timesteps"], "ppo_n_steps": n_steps,
        "env_share_of_sac_time": sac["share"], "sac_learn_seconds": sac["learn_seconds"],
        "sac_env_seconds": sac["env_seconds"], "sac_timesteps": sac["timesteps"],
    }  # fmt: skip


def bench(quick: bool = False, envs: bool = True, ppo: bool = True, pade_order: int | None = None,
          reference_samples: int | None = None, labels: bool = True) -> dict[str, Any]:  # fmt: skip
    """Every figure of ``deadtime bench`` as one dict (see the module docstring)."""
    start = time.perf_counter()
    figures: dict[str, Any] = {"quick": quick, "machine": machine_info()}
    figures.update(_scoring_part(quick, pade_order, reference_samples))
    if envs:
        figures.update(_env_part(quick))
        figures.update(_vector_part(quick))
    if labels:
        figures.update(_labels_part(quick))
    if ppo:
        figures.update(_training_part(quick))
        figures.update(_ppo_native_part(quick))
    for key in HEADLINE:  # skipped parts: null in the JSON
        figures.setdefault(key, None)
    figures["machine"]["load_average_end"] = list(os.getloadavg())
    figures["bench_seconds"] = time.perf_counter() - start
    return figures


def _format(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3g}"
    if value is None:
        return "-"
    return str(value)


ROWS = (
    ("Scoring (score(): load and set-point IAE, Ms, GM, PM, DM, stability), one core", None),
    ("scorings_per_s_single", "our scorings/s, one loop at a time"),
    ("scorings_per_s_batched", "our scorings/s, batched"),
    ("batched_method", "  batched via"),
    ("margins_per_s", "  robustness alone, loops/s"),
    ("iae_per_s_single", "  IAE alone, loops/s"),
    ("iae_per_s_batched", "  IAE alone batched, loops/s"),
    ("scorings_per_s_python_control", "python-control scorings/s"),
    ("iae_per_s_python_control", "  IAE alone (forced_response), loops/s"),
    ("iae_per_s_scipy_dlsim", "  IAE alone (scipy.signal.dlsim, ZOH), loops/s"),
    ("speedup_vs_python_control", "speed-up vs python-control"),
    ("speedup_batched_vs_python_control", "speed-up vs python-control, batched"),
    ("Accuracy (largest relative IAE error vs the fine-step reference)", None),
    ("accuracy_ours", "ours"),
    ("accuracy_python_control", "python-control"),
    ("accuracy_ours_median", "ours, median"),
    ("accuracy_python_control_median", "python-control, median"),
    ("pade_order", "Padé order"),
    ("python_control_step", "python-control step"),
    ("our_step", "our step"),
    ("margin_agreement", "margins ours vs python-control (rel.)"),
    ("Environments (episodes/s, DeadTime/PID-v0, random actions)", None),
    ("episodes_per_s_fixed", "single, fixed"),
    ("episodes_per_s_agent", "single, agent"),
    ("Native vector environment (DeadTime/PID-v0, fixed mode, one core)", None),
    ("episode_floor_ms", "compiled-arithmetic floor of an episode, ms"),
    ("episode_floor_native32_ms", "  the same, native x32, ms"),
    ("episode_ms_single", "episode, single, ms"),
    ("episode_ms_native32", "episode, native x32, ms"),
    ("episode_to_floor_single", "episode / floor, single"),
    ("episode_to_floor_native32", "episode / floor, native x32"),
    ("native32_vs_single", "episodes/s native x32 / single"),
    ("episode_bound_ms", "bit-identical bound of an episode, ms"),
    ("episode_bound_single_ms", "  in single episodes, ms"),
    ("episode_bound_native32_ms", "  in native x32 episodes, ms"),
    ("native32_vs_single_bound", "  largest native x32 / single it allows"),
    ("vector_rounds", "rounds (figures: medians over them)"),
    ("Labels (a reset and the oracle's action per training plant, DeadTime/PID-v3 plan [1, 1], one core)", None),
    ("labels_per_s_reference", "labels/s, reference search"),
    ("labels_per_s_fast", "labels/s, fast search"),
    ("labels_fast_vs_reference", "fast / reference"),
    ("label_reset_ms", "  the reset alone (both), ms"),
    ("oracle_fast_vs_reference", "  the oracle alone, fast / reference"),
    ("labels_fast_vs_reference_bound", "  largest fast / reference the reset allows"),
    ("labels_rounds", "rounds (figures: medians over them)"),
    ("Training", None),
    ("ppo_samples_per_s_native1", "PPO samples/s of learn, native x1"),
    ("ppo_samples_per_s_native8", "PPO samples/s of learn, native x8"),
    ("ppo_samples_per_s_native32", "PPO samples/s of learn, native x32"),
    ("ppo_samples_per_s_native32_vs_1", "  x32 / x1"),
    ("env_share_of_ppo_native1", "environment share of PPO.learn, native x1"),
    ("env_share_of_ppo_native8", "environment share of PPO.learn, native x8"),
    ("env_share_of_ppo_native32", "environment share of PPO.learn, native x32"),
    ("env_share_of_ppo_time", "environment share of PPO.learn, one env (dummy)"),
    ("ppo_learn_seconds", "learn seconds"),
    ("ppo_timesteps", "timesteps"),
    ("env_share_of_sac_time", "environment share of SAC.learn (configs/sac.yaml)"),
    ("sac_learn_seconds", "learn seconds"),
    ("sac_timesteps", "timesteps"),
)


def format_table(figures: dict[str, Any]) -> str:
    """The human-readable table."""
    lines = []
    for key, label in ROWS:
        if label is None:
            lines.append(f"\n{key}")
        elif key in figures:
            lines.append(f"  {label:48s} {_format(figures[key])}")
        if key == "native32_vs_single":
            for name, rate in figures.get("episodes_per_s_native", {}).items():
                lines.append(f"  {'episodes/s, ' + name:48s} {_format(rate)}")
        if key == "episodes_per_s_agent":
            for name, rate in figures.get("episodes_per_s", {}).items():
                if name not in ("single/fixed", "single/agent"):
                    lines.append(f"  {name:48s} {_format(rate)}")
    m = figures["machine"]
    lines.append(
        f"\nMachine: {m['cpu_count']} CPUs, load {m['load_average'][0]:.2f}, python {m['python']}, commit {m['commit']}"
        + (" (envs/ has uncommitted changes)" if m["envs_uncommitted_changes"] else "")
        + f"; BLAS/OpenMP/numba threads {m['thread_variables'].get('OPENBLAS_NUM_THREADS') or 'default'}"
        + f"; bench took {figures['bench_seconds']:.0f} s"
    )
    return "\n".join(lines).lstrip("\n")
