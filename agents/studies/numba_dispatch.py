"""What numba's dispatch costs per fixed-mode episode (docs/performance.md, "The bit-identical bound").

Plays fixed-mode episodes of ``DeadTime/PID-v0`` in the native vector environment (32 slots), once to
compile every kernel for their argument types, then the same episodes again while it
records one argument tuple of every numba kernel of :mod:`envs` and how often each is called, then
times an empty compiled function called with those same arguments: the cost of dispatching the
call (typing the arguments, unboxing them) without the kernel's work.  Their sum per episode is what
calling every kernel once per batch instead of once per plant could save at most.

    OPENBLAS_NUM_THREADS=1 NUMBA_NUM_THREADS=1 taskset -c 0 deadtime study numba-dispatch
"""

from __future__ import annotations

import sys
import time

import gymnasium
import numba
from numba.core.registry import CPUDispatcher

import envs  # noqa: F401  (registers the ids)

SLOTS, ROUNDS, CALLS = 32, 2, 2000
LIMITS = {"--slots": 1024, "--rounds": 100, "--calls": 1_000_000}
"""The largest value of each argument: a few minutes of work at most (the defaults take seconds)."""


@numba.njit
def _empty(*args):  # pragma: no cover - compiled
    return 0


def _kernels() -> list[tuple[object, str, CPUDispatcher]]:
    return [(module, name, value) for key, module in list(sys.modules.items())
            if module is not None and (key == "envs" or key.startswith("envs."))
            for name, value in list(vars(module).items()) if isinstance(value, CPUDispatcher)]


def _play(vec, rounds: int) -> None:
    """``rounds`` batches of fixed-mode episodes from seed 0 (the same episodes at every call)."""
    vec.action_space.seed(0)
    vec.reset(seed=0)
    for _ in range(rounds):
        vec.step(vec.action_space.sample())


def numba_dispatch(slots: int = SLOTS, rounds: int = ROUNDS, calls: int = CALLS) -> str:
    """One line per kernel (calls per episode, arguments, dispatch time) and the total per episode."""
    if min(slots, rounds, calls) < 1:
        raise ValueError(f"--slots, --rounds and --calls must be at least 1, got {slots}, {rounds}, {calls}")
    for name, value in zip(LIMITS, (slots, rounds, calls)):
        if value > LIMITS[name]:
            raise ValueError(f"{name} must be at most {LIMITS[name]}, got {value}")
    vec = gymnasium.make_vec("DeadTime/PID-v0", num_envs=slots, experiments="fixed")
    _play(vec, rounds)  # the same episodes played once unrecorded: every kernel compiled for their types
    seen: dict[str, list] = {}

    def recording(function, label):
        def wrapper(*args, **kwargs):
            seen.setdefault(label, [0, args])[0] += 1
            return function(*args, **kwargs)
        return wrapper

    kernels, wrappers = _kernels(), {}
    for module, name, function in kernels:
        setattr(module, name, wrappers.setdefault(id(function), recording(function, function.__name__)))
    try:
        _play(vec, rounds)
    finally:
        for module, name, function in kernels:
            setattr(module, name, function)
    vec.close()
    episodes, total, lines = slots * rounds, 0.0, []
    for label, (count, args) in sorted(seen.items(), key=lambda item: -item[1][0]):
        _empty(*args)
        start = time.perf_counter()
        for _ in range(calls):
            _empty(*args)
        each = (time.perf_counter() - start) / calls
        total += each * count / episodes
        lines.append(f"{label:28s} calls/episode {count / episodes:5.2f}  arguments {len(args):2d}  dispatch {1e6 * each:6.2f} us")
    lines.append(f"numba dispatch per episode: {1e6 * total:.1f} us")
    return "\n".join(lines)
