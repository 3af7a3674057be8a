"""Where the protocol's tasks run: in this process one after another, or as Ray tasks, locally or on a cluster.

:func:`workers` gives a function ``run(tasks) -> folders`` that runs every task of a list
(:func:`agents.protocol.tasks.run_task`) and returns their results in the list's order, whatever the
order in which they finish:

* ``workers`` 1 (or 0) and no address: in this process, in order; Ray is not needed.
* ``workers`` N > 1: a new local Ray instance of N CPUs, one task per CPU.
* ``address``: the Ray cluster there, joined as ``deadtime sweep`` joins it (:func:`agents.sweeps.cluster.connect`:
  token authentication, one line when refused), one task per CPU of the cluster.  A task runs in the
  driver's working directory (the protocol's relative paths hold there), so every node needs this
  checkout at the same path and ``--out`` (and ``--fits``) on a file system every node sees: a task
  writes its own folder there (a fit's run directory, a chunk's evaluation), the driver reads them.

A task that fails is named in one line (its error's last line); Ctrl-C or SIGTERM in the driver stops the
run, the tasks' finished outputs kept (:mod:`agents.interruptions` ends the local Ray instance).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from agents.protocol.tasks import Chunk, Fit, run_task

__all__ = ["workers"]

Runner = Callable[[list[Fit | Chunk]], list[str]]


def _say(line: str) -> None:
    print(f"deadtime protocol: {line}", file=sys.stderr, flush=True)


def _serial(tasks: list[Fit | Chunk]) -> list[str]:
    results = []
    for number, task in enumerate(tasks, start=1):
        results.append(run_task(task))
        _say(f"{task.name} done ({number} of {len(tasks)})")
    return results


def _failure(task: Fit | Chunk, error: Any) -> ValueError:
    cause = getattr(error, "cause", None) or error
    lines = str(cause).strip().splitlines()
    return ValueError(f"{task.name} failed: {type(cause).__name__}: {lines[-1] if lines else ''} (the finished tasks' "
                      "outputs are kept: --resume continues)")


def _run_in(directory: str, task: Fit | Chunk) -> str:
    """:func:`run_task` in ``directory`` (the driver's working directory: the protocol's relative paths hold)."""
    import os

    os.chdir(directory)
    return run_task(task)


def _on_ray(ray: Any) -> Runner:
    import os

    remote = ray.remote(num_cpus=1, max_retries=0)(_run_in)

    def run(tasks: list[Fit | Chunk]) -> list[str]:
        refs = [remote.remote(os.getcwd(), task) for task in tasks]
        with _sigterm_said():
            return _collect(ray, tasks, refs)

    return run


def _collect(ray: Any, tasks: list[Fit | Chunk], refs: list[Any]) -> list[str]:
    """The result of each task of ``refs``, at its place in ``tasks``, whatever order they finish in."""
    index = {ref: k for k, ref in enumerate(refs)}
    results: list[str | None] = [None] * len(tasks)
    pending = list(refs)
    while pending:
        done, pending = ray.wait(pending, num_returns=1, timeout=1.0)  # a timeout: signals are seen in between
        for ref in done:
            task = tasks[index[ref]]
            try:
                results[index[ref]] = ray.get(ref)
            except ray.exceptions.RayError as error:  # the task's own error, or its worker or node lost
                raise _failure(task, error) from None
            _say(f"{task.name} done ({len(tasks) - len(pending)} of {len(tasks)})")
    return [str(result) for result in results]


@contextmanager
def _sigterm_said() -> Iterator[None]:
    """SIGTERM while the driver waits on Ray leaves as :class:`agents.interruptions.Terminated`: Ray's wait
    turns an exception raised by a signal's handler into a plain ``KeyboardInterrupt``."""
    import signal
    import threading

    from agents.interruptions import Terminated

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []

    def handle(signum: int, frame: Any) -> None:
        received.append(signum)
        raise Terminated

    previous = signal.signal(signal.SIGTERM, handle)
    try:
        yield
    except KeyboardInterrupt as error:
        if received and not isinstance(error, Terminated):
            raise Terminated from error
        raise
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextmanager
def workers(count: int = 1, address: str | None = None) -> Iterator[Runner]:
    """The runner of ``count`` local workers, or of the cluster at ``address`` (module docstring).

    Raises
    ------
    ValueError
        In one line: Ray is not installed, the address is refused, or ``count`` is negative.
    """
    if count < 0:
        raise ValueError(f"--workers must be >= 0, got {count}")
    if not address and count <= 1:
        yield _serial
        return
    try:
        import ray
    except ImportError:
        raise ValueError("deadtime protocol run with --workers > 1 or --address needs Ray: pip install -e '.[sweep]'") from None
    from agents.sweeps.cluster import connect

    connect(ray, address, cpus=None if address else count)
    try:
        yield _on_ray(ray)
    finally:
        ray.shutdown()
