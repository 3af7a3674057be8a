"""The bench's timing of compiled and library calls (agents/bench/floor.py): what it wraps, that it
restores every function, and that a call inside another timed call is counted once."""

from __future__ import annotations

import numpy as np
import scipy.linalg
from scipy.linalg import _matfuncs

from agents.bench.floor import CompiledTime, _timed, compiled_calls_timed
from envs.identification.experiment_base import MeasurementNoise


def _episodes(count: int = 3) -> None:
    from agents.environments import make_env

    env = make_env("DeadTime/PID-v0", {"experiments": "fixed"})
    env.reset(seed=0)
    for _ in range(count):
        env.step(np.zeros(1, dtype=np.float32))
        env.reset()
    env.close()


def test_compiled_calls_are_timed_and_restored() -> None:
    _episodes()  # compile the kernels first (module docstring)
    originals = (scipy.linalg.expm, np.linalg.eigvals, np.einsum, MeasurementNoise._fill)  # noqa: SLF001
    with compiled_calls_timed() as record:
        _episodes()
    assert record.calls > 0 and record.seconds > 0 and record.depth == 0
    assert "expm" in record.by_name and "eigvals" not in record.by_name
    assert (scipy.linalg.expm, np.linalg.eigvals, np.einsum, MeasurementNoise._fill) == originals  # noqa: SLF001


def test_library_calls_replace_expm_by_its_kernels() -> None:
    _episodes()
    kernels = (_matfuncs.pick_pade_structure, _matfuncs.pade_UV_calc)
    with compiled_calls_timed(library=True) as record:
        _episodes()
    assert {"eigvals", "einsum", "_fill", "pade_UV_calc", "pick_pade_structure"} <= set(record.by_name)
    assert "bandwidth" not in record.by_name
    assert "expm" not in record.by_name
    assert (_matfuncs.pick_pade_structure, _matfuncs.pade_UV_calc) == kernels


def test_a_nested_timed_call_is_counted_once() -> None:
    record = CompiledTime()
    inner = _timed(lambda: 1, "inner", record, 0.0)
    outer = _timed(lambda: inner() + 1, "outer", record, 0.0)
    assert outer() == 2
    assert record.calls == 1 and set(record.by_name) == {"outer"} and record.depth == 0
    assert inner() == 1 and record.calls == 2
