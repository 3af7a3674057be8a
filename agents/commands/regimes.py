"""``deadtime regimes``: sweeps that differ only in their regime (``env_kwargs``), side by side.

::

    deadtime regimes runs/experiments_noise01_time runs/experiments_noise10_time ... \\
        --x noise_std --out results/superseded/experiments

What it computes and writes: :mod:`agents.sweeps.regimes`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from agents.commands.arguments import require_directory
from agents.limits import MAX_EVAL_EPISODES, MAX_RESAMPLES, require_at_most

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime regimes``."""
    parser.add_argument("sweeps", nargs="+", help="output directories of finished sweeps that set env_kwargs")
    parser.add_argument("--x", required=True, help="the env_kwargs key on the plot's axis, e.g. noise_std")
    parser.add_argument("--compare", default="", help="A,B[,C...]: the paired difference mean(A) - mean(B) for each B, "
                        "A an agent label, B an agent label, a rule or a procedure")
    parser.add_argument("--behaviour", type=int, default=0,
                        help=f"replay each agent on this many validation plants (at most {MAX_EVAL_EPISODES})")
    parser.add_argument("--resamples", type=int, default=2000, help=f"bootstrap resamples (default 2000, at most {MAX_RESAMPLES})")
    parser.add_argument("--out", required=True, help="output directory")


def run(args: argparse.Namespace) -> int:
    """Run ``deadtime regimes``; bad input is a ValueError (one line, exit status 2)."""
    from agents.sweeps.regimes import compare_regimes, markdown, write_outputs

    require_directory(args.out)
    require_at_most(args.behaviour, MAX_EVAL_EPISODES, "--behaviour")
    require_at_most(args.resamples, MAX_RESAMPLES, "--resamples")
    compare = tuple(item for item in args.compare.split(",") if item)
    if compare and len(compare) < 2:
        raise ValueError(f"--compare must name an agent label and what to compare it with, A,B[,C...], got {args.compare!r}")
    if args.behaviour < 0 or args.resamples <= 0:
        raise ValueError("--behaviour must be >= 0 and --resamples > 0")
    result = compare_regimes([Path(p) for p in args.sweeps], args.x, compare, args.behaviour, args.resamples)
    text = markdown(result)  # before anything is written: the three files come from one result or none
    out = Path(args.out)
    write_outputs(out, result, text)
    print(text)
    print(f"wrote {out / 'regimes.md'} (and .json, .png)", file=sys.stderr)
    return 0
