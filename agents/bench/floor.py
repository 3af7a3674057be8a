"""``deadtime bench``: the compiled-arithmetic floor of an episode, measured.

An episode of a DeadTime environment is Python that orchestrates compiled calls: the numba
kernels of :mod:`envs` (the experiments' runs, the identification's sums, the IAE, the robustness
analysis, ...), ``scipy.linalg.expm`` of the discretizations and LAPACK's ``dgebal`` of the plant's
realization.  The *floor* of an episode is the wall time spent inside those calls, each call timed
whole (its dispatch included): what would remain if every line of Python between them cost
nothing.  The ratio of an episode's measured time to its floor says how much of it is Python.

:func:`compiled_calls_timed` measures it by replacing, for the duration of a ``with`` block, every
numba dispatcher bound to a name in a loaded ``envs`` module (and ``scipy.linalg.expm`` and the
``dgebal`` of :mod:`envs.systems.plants`) by a timing wrapper; the cost of the wrapper itself (two
clock reads, measured around an empty call) is subtracted per call.  Compiled code that calls
compiled code is timed once, as part of its outermost call.  Run the same episodes once without
the timers first: a kernel that has to be compiled while its neighbours are wrapped would see a
wrapper where it expects a dispatcher.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

__all__ = ["CompiledTime", "compiled_calls_timed"]


@dataclass
class CompiledTime:
    """Accumulated time inside compiled calls.

    Attributes
    ----------
    seconds : float
        Wall time inside the wrapped calls, the wrappers' own cost subtracted.
    calls : int
        Number of wrapped calls.
    by_name : dict of str to float
        ``seconds`` by the called function's name.
    """

    seconds: float = 0.0
    calls: int = 0
    by_name: dict[str, float] = field(default_factory=dict)


def _wrapper_cost(samples: int = 20_000) -> float:
    """Seconds a timing wrapper adds to one call (two clock reads and the bookkeeping)."""
    clock, noop, total = time.perf_counter, (lambda: None), 0.0
    start = clock()
    for _ in range(samples):
        begin = clock()
        noop()
        total += clock() - begin
    plain_start = clock()
    for _ in range(samples):
        noop()
    plain = clock() - plain_start
    return max(0.0, ((plain_start - start) - plain) / samples)


def _timed(function: Callable, name: str, record: CompiledTime, cost: float) -> Callable:
    clock = time.perf_counter

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        begin = clock()
        try:
            return function(*args, **kwargs)
        finally:
            spent = clock() - begin - cost
            record.seconds += spent
            record.calls += 1
            record.by_name[name] = record.by_name.get(name, 0.0) + spent

    return wrapper


def _targets() -> list[tuple[Any, str, Any]]:
    """``(namespace, attribute, function)`` of every compiled call site to wrap."""
    import scipy.linalg
    from numba.core.registry import CPUDispatcher

    found = [(scipy.linalg, "expm", scipy.linalg.expm)]
    for name, module in list(sys.modules.items()):
        if module is None or not (name == "envs" or name.startswith("envs.")):
            continue
        for attribute, value in list(vars(module).items()):
            if isinstance(value, CPUDispatcher) or attribute == "_DGEBAL":
                found.append((module, attribute, value))
    return found


@contextlib.contextmanager
def compiled_calls_timed(record: CompiledTime | None = None) -> Iterator[CompiledTime]:
    """Time every compiled call of :mod:`envs` inside the block into ``record`` (a new one if None),
    which the block receives (module docstring); the functions are restored on exit."""
    record, cost = record if record is not None else CompiledTime(), _wrapper_cost()
    targets = _targets()
    wrappers: dict[int, Callable] = {}
    for namespace, attribute, function in targets:
        label = getattr(function, "__name__", attribute)
        wrapper = wrappers.setdefault(id(function), _timed(function, label, record, cost))
        setattr(namespace, attribute, wrapper)
    try:
        yield record
    finally:
        for namespace, attribute, function in targets:
            setattr(namespace, attribute, function)
