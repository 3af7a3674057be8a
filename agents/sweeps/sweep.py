"""``deadtime sweep``: a study of many training seeds and configs on Ray Tune, then its statistics.

::

    deadtime sweep --config sweeps/NAME.yaml --out DIR [--address ADDR] [--resume] [--json]

The sweep file (:mod:`agents.sweeps.config`) lists training configs x environment ids x seeds.  Each
``(config, env, seed)`` is one Ray Tune trial (one CPU) that calls the training function of
``deadtime train`` (:func:`agents.training.train.train`) with the run directory ``DIR/runs/NAME``; the trial
reports its progress to Tune from a stable-baselines3 callback.  Then every trained agent, and the
rules and the oracle once per environment, are evaluated on the held-out plants as Ray tasks (the
evaluation of ``deadtime evaluate``, into ``DIR/eval/...``), and :mod:`agents.sweeps.summary` writes
``DIR/summary.{md,csv,json}`` and the plots.

* **Where it runs.**  Without ``--address`` (or ``RAY_ADDRESS``) ``ray.init`` starts a local Ray
  instance with one CPU per core.  With an address it joins that cluster: every node must have this
  package installed (``pip install -e '.[sweep]'`` in the same path), and ``--out`` must be a
  directory every node sees (a shared file system), because Tune's ``storage_path``, the run
  directories and the evaluations all live in it.
* **Interruptions.**  Training checkpoints are ``deadtime train``'s own (atomic; a trial always
  resumes its run directory), Tune's experiment state is in ``DIR/tune``.  ``--resume`` restores it
  (``Tuner.restore``): finished trials are kept, unfinished ones continue from their latest
  checkpoint, errored ones are retried.  Evaluations are cached per plant.
* **Failures.**  A failed trial is retried ``failure.max_failures`` times (``FailureConfig``); if it
  keeps failing it is reported by name with its error, and the summary is made of the others.
* **Threads.**  One thread for torch, BLAS, OpenMP and numba in every trial and task (the matrices
  are tiny; parallelism comes from the trials).
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from agents.limits import MAX_RESAMPLES, MAX_SEEDS, MAX_TEST_PLANTS
from agents.sweeps.config import load_sweep

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime sweep``."""
    parser.add_argument("--config", required=True,
                        help=f"a sweep file (sweeps/NAME.yaml).  Limits (agents/limits.py): at most {MAX_SEEDS} seeds per "
                        f"group, evaluation.n <= {MAX_TEST_PLANTS}, evaluation.resamples <= {MAX_RESAMPLES}, and those of "
                        "deadtime train for each config")
    parser.add_argument("--out", required=True, help="the sweep's directory (runs, evaluations, summary)")
    parser.add_argument("--address", help="a Ray cluster's address (default: RAY_ADDRESS, else a local instance)")
    parser.add_argument("--resume", action="store_true", help="finish an interrupted sweep in --out")
    parser.add_argument("--json", action="store_true", help="print summary.json")


def run(args: argparse.Namespace) -> int:
    """``deadtime sweep``: check the sweep, run it, print the summary."""
    from agents.commands.arguments import require_directory

    require_directory(args.out)
    sweep = load_sweep(args.config)
    try:
        from agents.sweeps.run import run_sweep
    except ImportError as error:
        if error.name is None or not error.name.startswith("ray"):
            raise
        raise ValueError("deadtime sweep needs Ray Tune: pip install -e '.[sweep]'") from None
    summary = run_sweep(sweep, Path(args.config), Path(args.out), address=args.address or os.environ.get("RAY_ADDRESS"),
                        resume=args.resume)
    if args.json:
        print(json.dumps(summary))
    else:
        print((Path(args.out) / "summary.md").read_text(), end="")
    return 0
