"""``deadtime frontier``: any policy on a regime's frontier, cost against risk over its knob.

::

    deadtime frontier --env DeadTime/PID-v3 --policies amigo-pid,gorez-klan-mu-2,mine=my_module:policy \\
        --knobs=-0.5,0,0.5,1 --n 200 --seed 0 --out results/frontier-pid

The families, the frontier and its outputs: :mod:`agents.frontier` (docs/frontier.md).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from agents.commands.arguments import CommandError, load_json_argument, require_directory
from agents.limits import MAX_TEST_PLANTS, MAX_WORKERS

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime frontier``."""
    parser.add_argument("--env", required=True, help="environment id, e.g. DeadTime/PID-v3")
    parser.add_argument(
        "--policies", required=True,
        help="comma-separated: rule names or all-rules (the structure's), learned-pid@0.01 (a shipped learner at a risk), "
             "module:function or NAME=module:function (a Python callable observation -> "
             "action), agent, learned-rule or selector paths or NAME=PATH, PATH a glob whose matches are one family's "
             "seeds (loading an agent runs pickled code from its folder: load only agents you trust)",
    )  # fmt: skip
    parser.add_argument("--knobs", help="comma-separated knob values s (s > 0 more conservative; 0 is always added; "
                        "default -1,-0.5,-0.25,0,0.25,0.5,1,1.5,2); write --knobs=-1,0,1 for a leading minus")
    parser.add_argument("--n", type=int, default=200, help=f"validation plants (default 200, at most {MAX_TEST_PLANTS})")
    parser.add_argument("--seed", type=int, default=0, help="episode seeds are seed + plant index (an integer >= 0, default 0)")
    parser.add_argument("--out", required=True, help="output directory (created; not the empty string)")
    parser.add_argument("--env-kwargs", help="a JSON object of environment arguments (or a file of one) that set the regime, "
                        "e.g. '{\"noise_std\": 0.1}'; not 'experiments'")
    parser.add_argument("--workers", type=int, default=1, help=f"processes for the rules and the oracle (default 1, at most {MAX_WORKERS})")
    parser.add_argument("--no-plots", action="store_true", help="write the tables only")
    parser.add_argument("--json", action="store_true", help="print frontier.json to stdout")


def _knobs(text: str | None) -> list[float]:
    from agents.frontier.frontier import DEFAULT_KNOBS

    if text is None:
        return list(DEFAULT_KNOBS)
    try:
        return [float(item) for item in text.split(",")]
    except ValueError:
        raise CommandError(f"--knobs must be comma-separated numbers, got {text!r}") from None


def _check_sizes(args: argparse.Namespace) -> None:
    for name, value, low, high in (("--n", args.n, 2, MAX_TEST_PLANTS), ("--workers", args.workers, 1, MAX_WORKERS)):
        if not low <= value <= high:
            raise CommandError(f"{name} must be an integer from {low} to {high}, got {value}")
    if args.seed < 0:
        raise CommandError(f"--seed must be an integer >= 0, got {args.seed}")


def run(args: argparse.Namespace) -> int:
    """Run ``deadtime frontier``; bad input is a ValueError (one line, exit status 2)."""
    from agents.environments import make_env
    from agents.frontier.frontier import frontier
    from agents.frontier.policies import parse_families
    from agents.frontier.report import frontier_markdown, write_frontier
    from envs.interface import tuning_env_of

    out = require_directory(args.out)
    _check_sizes(args)
    knobs = _knobs(args.knobs)
    regime = None if args.env_kwargs is None else load_json_argument(args.env_kwargs, "--env-kwargs")
    env = make_env(args.env)  # an unknown id is named before any policy is loaded
    structure = tuning_env_of(env).structure.lower()
    env.close()
    families = parse_families(args.policies, structure)
    result = frontier(args.env, families, knobs, n=args.n, seed=args.seed, env_kwargs=regime, workers=args.workers, out=out)
    write_frontier(out, result, plots=not args.no_plots)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(frontier_markdown(result))
        print(f"wrote {out / 'frontier.md'} (and .csv, .json{'' if args.no_plots else ', .png'}, cache.jsonl)", file=sys.stderr)
    return 0

