"""What every command starts with and what it records: the thread defaults and the provenance.

* **Threads.**  One thread for the linear algebra and the compiled kernels
  (:data:`THREAD_VARIABLES`), unless the user says otherwise: the matrices here are tiny, and
  OpenBLAS's threads made ``scipy.linalg.expm`` about 10 times slower on 2 cores (measured by
  ``deadtime bench``); parallelism comes from vectorized environments, ``--workers`` and Ray trials
  instead; torch's CPU threads (``OMP_NUM_THREADS``) likewise, for the small networks here.  The
  variables take effect only if set before numpy (torch, numba) is imported: importing ``agents``
  sets their defaults first thing (:func:`single_thread_defaults`; :mod:`agents` warns once if torch
  came first), and so do ``deadtime`` and every script that imports ``agents``; child processes (the
  bench's child, Ray's workers) get them in their environment.  This is the one place that defines them; the
  ``Makefile`` exports the same four with the same default (``make test`` sets them before pytest
  starts), and ``tests/unit/agents/test_runtime.py`` holds the two lists equal.
* **Provenance.**  The git commit of this code (:func:`git_commit`, ``-dirty`` with uncommitted
  changes) and the versions of the packages (:func:`versions`), recorded beside every result:
  ``deadtime train``'s ``config.yaml``, ``deadtime sweep``'s ``sessions.json``, ``deadtime bench
  --json``.
"""

from __future__ import annotations

import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

__all__ = ["PACKAGES", "REPO", "THREAD_VARIABLES", "git", "git_commit", "single_thread_defaults", "versions"]

THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")
"""The environment variables of the thread pools of OpenBLAS, OpenMP, MKL and numba."""

PACKAGES = ("numpy", "scipy", "numba", "control", "gymnasium", "stable-baselines3", "torch", "scikit-learn", "deadtime-gym")
"""The distributions whose versions a run records."""

REPO = Path(__file__).resolve().parents[1]
"""The checkout holding ``envs``, ``baselines`` and ``agents``."""


def single_thread_defaults() -> None:
    """Set each of :data:`THREAD_VARIABLES` to 1 where the user has not set it."""
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")


def git(*args: str) -> str | None:
    """The output of ``git ARGS`` in :data:`REPO`, or ``None`` (no git, not a checkout, a failure)."""
    try:
        done = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, check=False, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def git_commit() -> str | None:
    """The full commit of :data:`REPO`'s ``HEAD``, with ``-dirty`` if tracked files have changed."""
    commit = git("rev-parse", "HEAD")
    if commit is None:
        return None
    dirty = git("status", "--porcelain", "--untracked-files=no")
    return commit + ("-dirty" if dirty else "")


def versions(packages: tuple[str, ...] = PACKAGES, missing: str | None = "not installed") -> dict[str, str | None]:
    """``{"python": ..., package: version}``, ``missing`` for a package that is not installed."""
    found: dict[str, str | None] = {"python": platform.python_version()}
    for name in packages:
        try:
            found[name] = metadata.version(name.replace("_", "-"))
        except metadata.PackageNotFoundError:
            found[name] = missing
    return found
