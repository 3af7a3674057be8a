"""``deadtime sweep``: a study of many training seeds and configs on Ray Tune, then its statistics.

::

    deadtime sweep --config configs/sweeps/NAME.yaml --out DIR [--address ADDR] [--resume] [--json]

The sweep file (:mod:`agents.sweeps.config`) lists training configs x environment ids x seeds.  Each
``(config, env, seed)`` is one Ray Tune trial (one CPU) that calls the training function of
``deadtime train`` (:func:`agents.training.train.train`) with the run directory ``DIR/runs/NAME``; the trial
reports its progress to Tune from a stable-baselines3 callback.  Then every trained agent, and the
rules and the oracle once per environment, are evaluated on the held-out plants as Ray tasks (the
evaluation of ``deadtime evaluate``, into ``DIR/eval/...``), and :mod:`agents.sweeps.summary` writes
``DIR/summary.{md,csv,json}`` and the plots.

* **Where it runs.**  Without ``--address`` (or ``RAY_ADDRESS``) a new local Ray instance starts
  with one CPU per core, never a cluster already running on the machine.  With an address it joins
  that cluster, with Ray's token authentication where the cluster uses it
  (:mod:`agents.sweeps.cluster`): every node must have this package installed (``pip install -e
  '.[sweep]'`` in the same path), and ``--out`` must be a directory every node sees (a shared file
  system), because Tune's ``storage_path``, the run directories and the evaluations all live in it.
* **Interruptions.**  Training checkpoints are ``deadtime train``'s own (atomic; a trial always
  resumes its run directory), Tune's experiment state is in ``DIR/tune``.  Ctrl-C stops the trials
  (:mod:`agents.sweeps.interrupts`), writes no summary, prints the command that resumes, and exits
  with status 130.  ``--resume`` first checks, reading only, the sweep's ``sessions.json`` and each
  trial's ``run.json`` and checkpoints (:mod:`agents.sweeps.resume`: a damaged one is named in one
  line, status 2; a fallback on an older checkpoint is said), then restores Tune's experiment
  (``Tuner.restore``): finished trials are kept, unfinished ones continue from their latest
  checkpoint, errored ones are retried.  An experiment state Tune cannot read is said in one line
  and its trials run again as a new experiment, each resuming its run directory.  Evaluations are
  cached per plant.  The summary's files are written together at the end (all or none).  Every
  session, an interrupted or killed one too, is recorded with its wall time in ``sessions.json``
  (:mod:`agents.sweeps.sessions`), and the summary's wall time is that of all of them.
* **Failures.**  A failed trial is retried ``failure.max_failures`` times (``FailureConfig``); if it
  keeps failing it is reported by name with its error, and the summary is made of the others.
* **Threads.**  One thread for torch, BLAS, OpenMP and numba in every trial and task (the matrices
  are tiny; parallelism comes from the trials).
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
from pathlib import Path

from agents.commands.arguments import require_directory
from agents.limits import MAX_RESAMPLES, MAX_SEEDS, MAX_TEST_PLANTS

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime sweep``."""
    parser.add_argument("--config", required=True,
                        help=f"a sweep file (configs/sweeps/NAME.yaml).  Limits (agents/limits.py): at most {MAX_SEEDS} seeds per "
                        f"group, evaluation.n <= {MAX_TEST_PLANTS}, evaluation.resamples <= {MAX_RESAMPLES}, and those of "
                        "deadtime train for each config")
    parser.add_argument("--out", required=True, help="the sweep's directory (runs, evaluations, summary)")
    parser.add_argument("--address", help="a Ray cluster's address (default: RAY_ADDRESS, else a new local instance); "
                        "a token for its authentication is taken from ~/.ray/auth_token, RAY_AUTH_TOKEN or "
                        "RAY_AUTH_TOKEN_PATH")
    parser.add_argument("--resume", action="store_true", help="finish an interrupted sweep in --out")
    parser.add_argument("--json", action="store_true", help="print summary.json")


def run(args: argparse.Namespace) -> int:
    """``deadtime sweep``: check the sweep, run it, print the summary."""
    from agents.sweeps.config import load_sweep

    require_directory(args.out)
    sweep = load_sweep(args.config)
    try:
        from agents.sweeps.run import run_sweep
    except ImportError as error:
        if error.name is None or not error.name.startswith("ray"):
            raise
        raise ValueError("deadtime sweep needs Ray Tune: pip install -e '.[sweep]'") from None
    address = args.address or os.environ.get("RAY_ADDRESS")
    try:
        summary = run_sweep(sweep, Path(args.config), Path(args.out), address=address, resume=args.resume)
    except KeyboardInterrupt as error:
        from agents.interruptions import Terminated, ignore_interrupts

        with ignore_interrupts():  # a second signal while the line is printed shows no traceback
            print(f"deadtime sweep: {'terminated' if isinstance(error, Terminated) else 'interrupted'}; no summary written, "
                  f"the trials' checkpoints and the evaluations' caches are kept; continue with: {_resume_command(args)}",
                  file=sys.stderr)
        return 143 if isinstance(error, Terminated) else 130
    if args.json:
        print(json.dumps(summary))
    else:
        print((Path(args.out) / "summary.md").read_text(), end="")
    return 0


def _resume_command(args: argparse.Namespace) -> str:
    """The command that finishes the interrupted sweep."""
    words = ["deadtime", "sweep", "--config", args.config, "--out", args.out]
    words += ["--address", args.address] if args.address else []
    return shlex.join([*words, "--resume"])
