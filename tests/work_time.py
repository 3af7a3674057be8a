"""Bounds on the work of a call, not on its wall time: ``with work_seconds() as work: ...`` then
``work.seconds``.

A test on a machine busy with other processes (``make test`` beside another ``make test``, two xdist
workers on two cores) waits for the CPU without doing more work, so a wall-clock bound fails there while
nothing is wrong.  The CPU time of this process counts only what it computes; the numba compiler's share
is taken out, since the first call of a kernel in a fresh clone compiles it (measured: 148 CPU seconds for
the first ``deadtime analyze`` under ``tracemalloc``) and that is a one-off cost of the installation,
not of the call.  Imported by name (``from work_time import work_seconds``): tests/conftest.py puts this
folder on ``sys.path``.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass


@dataclass
class WorkTime:
    """CPU seconds of the measured block outside numba's compiler (set when the block ends)."""

    seconds: float = 0.0
    compiler_seconds: float = 0.0


def _compiler_listener(record: WorkTime):
    from numba.core import event

    class CompilerTime(event.Listener):
        """Adds the CPU time of each outermost ``numba:compile`` event to ``record.compiler_seconds``."""

        depth, started = 0, 0.0

        def on_start(self, _event) -> None:
            if self.depth == 0:
                self.started = time.process_time()
            self.depth += 1

        def on_end(self, _event) -> None:
            self.depth -= 1
            if self.depth == 0:
                record.compiler_seconds += time.process_time() - self.started

    return CompilerTime()


@contextmanager
def work_seconds() -> Iterator[WorkTime]:
    """The block's CPU time (every thread of this process, ``time.process_time``) less the time numba spent
    compiling in it."""
    from numba.core import event

    record = WorkTime()
    listener = _compiler_listener(record)
    event.register("numba:compile", listener)
    started = time.process_time()
    try:
        yield record
    finally:
        event.unregister("numba:compile", listener)
        record.seconds = time.process_time() - started - record.compiler_seconds
