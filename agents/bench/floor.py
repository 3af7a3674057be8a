"""``deadtime bench``: the compiled-arithmetic floor of an episode, measured.

An episode of a DeadTime environment is Python that orchestrates compiled calls: the numba
kernels of :mod:`envs` (the experiments' runs, the identification's sums, the IAE, the robustness
analysis, ...), ``scipy.linalg.expm`` of the discretizations and LAPACK's ``dgebal`` of the plant's
realization.  The *floor* of an episode is the wall time spent inside those calls, each call timed
whole (its dispatch included): what would remain if every line of Python between them cost
nothing.  The ratio of an episode's measured time to its floor says how much of it is Python.

:func:`compiled_calls_timed` measures it by replacing, for the duration of a ``with`` block, every
numba dispatcher bound to a name in a loaded ``envs`` module (and ``scipy.linalg.expm`` and the
``dgebal`` of :mod:`envs.systems.state_space`) by a timing wrapper; the cost of the wrapper itself (two
clock reads, measured around an empty call) is subtracted per call.  Compiled code that calls
compiled code is timed once, as part of its outermost call.  Run the same episodes once without
the timers first: a kernel that has to be compiled while its neighbours are wrapped would see a
wrapper where it expects a dispatcher.

``library=True`` measures instead a lower bound of any *bit-identical* episode: the time of the
calls that a batch path giving the same bytes would still have to make one plant at a time,
because no compiled code of ours reproduces their rounding.  They are our numba kernels, LAPACK's
``dgebal``, the two compiled kernels of ``scipy.linalg.expm`` (``pick_pade_structure`` and
``pade_UV_calc``; its Python around them is left out, and so is its ``bandwidth``, a decision a
batch can take exactly), numpy's ``linalg.eigvals`` (the plant's poles), ``linalg.solve`` and
``einsum`` (the discretization's products) and the measurement noise's standard normals
(:meth:`~envs.identification.experiment_base.MeasurementNoise._fill`).  Matrix products by ``@``,
the plant draws and the construction of the noise generators are left out too, so the bound is on
the low side.  A call inside another timed call is counted once, in the outer one.
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
    depth: int = 0  # timed calls in progress (a nested one is not counted)


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
        if record.depth:
            return function(*args, **kwargs)
        record.depth += 1
        begin = clock()
        try:
            return function(*args, **kwargs)
        finally:
            spent = clock() - begin - cost
            record.depth -= 1
            record.seconds += spent
            record.calls += 1
            record.by_name[name] = record.by_name.get(name, 0.0) + spent

    return wrapper


def _targets(library: bool) -> list[tuple[Any, str, Any]]:
    """``(namespace, attribute, function)`` of every compiled call site to wrap (and with ``library``
    the library calls of the module docstring)."""
    import numpy
    import scipy.linalg
    from numba.core.registry import CPUDispatcher

    if not library:
        found = [(scipy.linalg, "expm", scipy.linalg.expm)]
    else:  # of scipy's expm, only its compiled kernels: its Python around them is not needed for its bytes
        from scipy.linalg import _matfuncs

        from envs.identification.experiment_base import MeasurementNoise

        found = [(_matfuncs, name, getattr(_matfuncs, name)) for name in ("pick_pade_structure", "pade_UV_calc")]
        found += [(numpy.linalg, "eigvals", numpy.linalg.eigvals), (numpy.linalg, "solve", numpy.linalg.solve),
                  (numpy, "einsum", numpy.einsum), (MeasurementNoise, "_fill", MeasurementNoise._fill)]  # noqa: SLF001
    for name, module in list(sys.modules.items()):
        if module is None or not (name == "envs" or name.startswith("envs.")):
            continue
        for attribute, value in list(vars(module).items()):
            if isinstance(value, CPUDispatcher) or attribute == "_DGEBAL":
                found.append((module, attribute, value))
    return found


@contextlib.contextmanager
def compiled_calls_timed(record: CompiledTime | None = None, library: bool = False) -> Iterator[CompiledTime]:
    """Time every compiled call of :mod:`envs` (and with ``library`` the library calls a bit-identical
    batch would keep) inside the block into ``record`` (a new one if None), which the block receives
    (module docstring); the functions are restored on exit."""
    record, cost = record if record is not None else CompiledTime(), _wrapper_cost()
    targets = _targets(library)
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
