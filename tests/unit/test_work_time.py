"""tests/work_time.py: the CPU seconds of a block outside numba's compiler, the bound the timed tests use
instead of wall time."""

from __future__ import annotations

import resource
import time

import numba

from work_time import work_seconds


def _cpu_by_rusage() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _busy(seconds: float) -> None:
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass


def test_computing_counts_as_getrusage_counts_it():
    """Cross-checked against ``getrusage`` (another clock of the same CPU time; microsecond resolution)."""
    before = _cpu_by_rusage()
    with work_seconds() as work:
        _busy(0.3)
    assert abs(work.seconds - (_cpu_by_rusage() - before)) < 0.02 and work.seconds >= 0.3


def test_waiting_does_not_count():
    with work_seconds() as work:
        time.sleep(0.3)
    assert work.seconds < 0.05


def test_the_compilers_time_is_taken_out():
    @numba.njit(cache=False)  # a new function: compiled inside the block
    def add(a, b):
        return a + b

    with work_seconds() as work:
        assert add(1.0, 2.0) == 3.0
    assert work.compiler_seconds > 0.0 and work.seconds < work.compiler_seconds
    with work_seconds() as again:  # compiled already: nothing taken out
        add(1.0, 2.0)
    assert again.compiler_seconds == 0.0
