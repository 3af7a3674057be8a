"""``deadtime evaluate``: policies against every rule and the per-plant oracle on held-out plants.

::

    deadtime evaluate --env DeadTime/PID-v0 --policies all-rules,oracle,agent=runs/x/model.zip \\
        --n 50 --seed 0 --out results/pid

The evaluation, its plants, seeds, statistics and outputs: :mod:`agents.evaluation.evaluate`.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from agents.commands.arguments import PLANT_COEFFICIENTS, load_json_argument, require_directory
from agents.limits import MAX_RESAMPLES, MAX_TEST_PLANTS, MAX_WORKERS

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime evaluate``."""
    parser.add_argument("--env", required=True, help="environment id, e.g. DeadTime/PID-v3")
    parser.add_argument(
        "--policies", required=True,
        help="comma-separated: rule names, all-rules, oracle, oracle-full, agent paths or NAME=PATH (loading an "
             "agent runs pickled code from its folder: load only agents you trust; its files are checked against "
             "the manifest written when it was saved)",
    )  # fmt: skip
    parser.add_argument("--n", type=int, default=50,
                        help=f"number of random held-out test plants (default 50, at most {MAX_TEST_PLANTS})")
    parser.add_argument("--plants", help="a JSON list of plants (each {\"num\": [...], \"den\": [...], \"delay\": L}) or a "
                        f"file of one: the user's own test set (at most {MAX_TEST_PLANTS} plants of at most {PLANT_COEFFICIENTS} "
                        "coefficients in num and in den), instead of --n random plants")
    parser.add_argument("--seed", type=int, default=0,
                        help="episode seeds are seed + plant index; also seeds the bootstrap (an integer >= 0, default 0)")
    parser.add_argument("--out", required=True, help="output directory (created; not the empty string)")
    parser.add_argument("--json", action="store_true", help="print results.json to stdout")
    parser.add_argument("--family", help="plant family of the test set (default: the environment's)")
    parser.add_argument("--env-kwargs", help="a JSON object of environment arguments (or a file of one) that set the "
                        "regime every policy is scored in, e.g. '{\"noise_std\": 0.1}'; not 'experiments'")
    parser.add_argument("--no-benchmark", action="store_true", help="leave out the papers' benchmark batch")
    parser.add_argument("--resamples", type=int, default=2000, help=f"bootstrap resamples (default 2000, at most {MAX_RESAMPLES})")
    parser.add_argument("--no-plots", action="store_true", help="write the tables only")
    parser.add_argument("--workers", type=int, default=1,
                        help=f"processes for the rules and oracles (default 1, at most {MAX_WORKERS})")


def run(args: argparse.Namespace) -> int:
    """Run ``deadtime evaluate``; bad input is a ValueError (one line, exit status 2)."""
    from agents.evaluation.evaluate import evaluate

    require_directory(args.out)
    plants = None if args.plants is None else load_json_argument(args.plants, "--plants")
    regime = None if args.env_kwargs is None else load_json_argument(args.env_kwargs, "--env-kwargs")
    result = evaluate(
        env_id=args.env, policies=args.policies, n=args.n, seed=args.seed, out=Path(args.out), family=args.family,
        benchmark=not args.no_benchmark, resamples=args.resamples, plots=not args.no_plots, workers=args.workers,
        plants=plants, env_kwargs=regime,
    )  # fmt: skip
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    from agents.evaluation.report import summary_table

    print(summary_table(result))
    plots = "" if args.no_plots else ", plots"
    print(f"wrote {Path(args.out) / 'results.md'} (and .csv, .json, per_plant.csv{plots})", file=sys.stderr)
    return 0
