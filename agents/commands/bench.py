"""``deadtime bench``: the speed and accuracy of the scoring and the environments, in one run.

Usage::

    deadtime bench [--json] [--quick] [--skip-envs] [--skip-ppo] [--skip-labels]

The parts and their figures: :mod:`agents.bench.bench`.  The bench runs in a child process whose
BLAS, OpenMP and numba pools have one thread (:data:`agents.runtime.THREAD_VARIABLES`, set before
numpy is imported); :data:`CHILD_VARIABLE` marks the child.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from typing import Any

from agents.limits import MAX_PADE_ORDER, MAX_REFERENCE_SAMPLES, require_at_most
from agents.runtime import REPO, THREAD_VARIABLES

__all__ = ["CHILD_VARIABLE", "add_arguments", "run"]

CHILD_VARIABLE = "DEADTIME_BENCH_CHILD"
"""Set to ``1`` in the environment of the bench's child process."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime bench``."""
    parser.add_argument("--json", action="store_true", help="print one JSON object with every figure")
    parser.add_argument("--quick", action="store_true", help="a smoke run (4 loops, one episode per setting: its rates are not measurements)")
    parser.add_argument("--skip-envs", action="store_true", help="skip the environment episodes")
    parser.add_argument("--skip-ppo", action="store_true", help="skip the training shares (PPO and SAC)")
    parser.add_argument("--skip-labels", action="store_true",
                        help="skip the labels (the oracle's fast search against its reference search)")
    parser.add_argument("--pade-order", type=int, default=None,
                        help=f"Padé order of the python-control reference (default 8, at most {MAX_PADE_ORDER})")
    parser.add_argument("--reference-samples", type=int, default=None,
                        help=f"python-control reference steps per plant time scale T_ar (default 50, at most {MAX_REFERENCE_SAMPLES})")  # fmt: skip


def _in_child(args: argparse.Namespace) -> dict[str, Any]:
    """Run the bench in a child process with one thread per pool (see the module docstring)."""
    from agents.files.reader import parse_json

    argv = [sys.executable, "-m", "agents.cli", "bench", "--json"]
    for flag, on in (("--quick", args.quick), ("--skip-envs", args.skip_envs), ("--skip-ppo", args.skip_ppo),
                     ("--skip-labels", args.skip_labels)):
        argv += [flag] if on else []
    for flag, value in (("--pade-order", args.pade_order), ("--reference-samples", args.reference_samples)):
        argv += [flag, str(value)] if value is not None else []
    root = str(REPO)
    path = os.environ.get("PYTHONPATH")
    env = {**os.environ, **dict.fromkeys(THREAD_VARIABLES, "1"), CHILD_VARIABLE: "1"}
    env["PYTHONPATH"] = root if not path else f"{root}{os.pathsep}{path}"
    done = subprocess.run(argv, env=env, cwd=root, stdout=subprocess.PIPE, text=True, check=False)
    if done.returncode != 0:
        raise ValueError(f"the bench's child process failed with status {done.returncode} (see its messages above)")
    return parse_json(done.stdout, "the output of the bench's child process", dict)


def run(args: argparse.Namespace) -> int:
    """Run the bench and print the table or the JSON object."""
    for name, value, limit in (("--pade-order", args.pade_order, MAX_PADE_ORDER),
                               ("--reference-samples", args.reference_samples, MAX_REFERENCE_SAMPLES)):
        if value is not None and value < 1:
            raise ValueError(f"{name} must be >= 1, got {value}")
        require_at_most(value, limit, name)
    from agents.bench.bench import bench, format_table

    if os.environ.get(CHILD_VARIABLE) == "1":
        figures = bench(args.quick, not args.skip_envs, not args.skip_ppo, args.pade_order, args.reference_samples,
                        not args.skip_labels)
    else:
        figures = _in_child(args)
    print(json.dumps(figures) if args.json else format_table(figures))
    if args.quick:
        print("bench --quick is a smoke run: it times one episode per setting (the first reset outside the timer), so its "
              "rates are not measurements; run deadtime bench without --quick for those", file=sys.stderr)
    return 0
