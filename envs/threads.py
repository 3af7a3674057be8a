"""One BLAS thread for this package's numerics, scoped to its own calls.

The matrices of this package are tiny (a loop's state has a few to a few dozen states), and
OpenBLAS's default of one thread per core makes them slower, not faster: its threads spin while
they wait.  Measured on a 2-core machine with numpy and scipy's OpenBLAS at their default of two
threads, ``DeadTime/PID-v0`` episodes (reset and one step) ran at 17 per second where one thread gave
373 (``OPENBLAS_NUM_THREADS=1``), and ``deadtime bench`` found ``scipy.linalg.expm`` of small
matrices about ten times slower.  The command line sets the thread variables before numpy loads;
a user of the Python API should not have to know.

So the public entry points (``Env.reset`` and ``Env.step``, :func:`envs.analysis.scoring.score`,
:func:`envs.analysis.loop_analysis.analyze`, the rules' ``tune`` and the oracle) run under
:func:`single_threaded`, which limits the BLAS libraries to one thread with ``threadpoolctl`` for
the duration of the call and restores the user's setting afterwards, so the rest of the user's
process (say, a large matrix product of their own) keeps its threads.  Where every BLAS library
already runs one thread (the command line, ``OPENBLAS_NUM_THREADS=1``) nothing is done; otherwise a
call pays for setting and restoring the limit (a few percent of an episode; docs/environments/overview.md, "Threads").

The limit is process-wide, as BLAS's thread count is: nested calls set it once, and concurrent
Python threads share one limit that the last of them to leave restores.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import Any, TypeVar

Function = TypeVar("Function", bound=Callable[..., Any])

_lock = threading.Lock()
_depth = 0
_limit: Any = None  # the active threadpoolctl limit, while _depth > 0


@functools.cache
def _blas_controller() -> Any:
    """The controller of the BLAS libraries (as loaded at the first call), or None where all of them
    already run one thread."""
    from threadpoolctl import ThreadpoolController

    controller = ThreadpoolController().select(user_api="blas")
    return controller if any(library.num_threads > 1 for library in controller.lib_controllers) else None


def _enter() -> None:
    global _depth, _limit
    with _lock:
        _depth += 1
        if _depth == 1:
            controller = _blas_controller()
            _limit = controller.limit(limits=1) if controller is not None else None


def _leave() -> None:
    global _depth, _limit
    with _lock:
        _depth -= 1
        if _depth == 0 and _limit is not None:
            _limit.restore_original_limits()
            _limit = None


def single_threaded(function: Function) -> Function:
    """Run ``function`` with one BLAS thread (module docstring); the result is unchanged."""

    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        _enter()
        try:
            return function(*args, **kwargs)
        finally:
            _leave()

    return wrapper  # type: ignore[return-value]
