"""Agents, rules and oracles on the DeadTime environments: training, evaluation, sweeps, ``deadtime``.

Importing ``agents`` applies the thread defaults of the command line
(:func:`agents.runtime.single_thread_defaults`: one thread for OpenBLAS, OpenMP, MKL and numba,
wherever the environment does not set the variable; torch's CPU threads follow ``MKL_NUM_THREADS``,
else ``OMP_NUM_THREADS``), so that a script that trains through stable-baselines3's own API or
calls :func:`evaluate` runs as fast as ``deadtime`` does: the networks and matrices here are tiny,
and more threads make them slower, not faster (docs/environments/overview.md, "Threads").  The defaults take effect only for the
libraries imported after ``agents``; if torch was imported first and runs more than one thread of
its own choosing, one ``RuntimeWarning`` says how to get the defaults.

:func:`evaluate` (:func:`agents.evaluation.evaluate.evaluate`, imported on first use) scores rules,
the oracle, saved agents and Python policies on held-out plants.
"""

from __future__ import annotations

import os
import sys
import warnings
from typing import Any

from agents.runtime import single_thread_defaults

__all__ = ["evaluate"]

_TORCH_THREADS = ("MKL_NUM_THREADS", "OMP_NUM_THREADS")
"""The variables torch's CPU thread count follows, the first set one."""


def _apply_thread_defaults() -> None:
    """:func:`single_thread_defaults`, and one warning if torch was imported before with threads the
    user did not choose."""
    chosen = any(name in os.environ for name in _TORCH_THREADS)
    single_thread_defaults()
    torch = sys.modules.get("torch")
    if chosen or torch is None or not hasattr(torch, "get_num_threads") or torch.get_num_threads() <= 1:
        return
    warnings.warn(
        f"torch was imported before agents and runs {torch.get_num_threads()} threads, which makes training and "
        "evaluating the small networks here several times slower; import agents first or call "
        "torch.set_num_threads(1) (setting MKL_NUM_THREADS or OMP_NUM_THREADS before starting Python keeps "
        "torch's threads and silences this)",
        RuntimeWarning,
        stacklevel=3,
    )


_apply_thread_defaults()


def __getattr__(name: str) -> Any:
    """:func:`evaluate`, imported on first use (``import agents`` stays light)."""
    if name == "evaluate":
        from agents.evaluation.evaluate import evaluate

        return evaluate
    raise AttributeError(f"module 'agents' has no attribute {name!r}")
