"""``deadtime tune``: the controller an analytic rule gives for a plant, and its analysis.

The rule and the analysis are :func:`baselines.rules.tune.tune`'s.  Exit status 3
(:data:`LOOP_PROBLEM`) when the rule's loop is unstable or outside the constraints on the plant, or
the rule's ``T_r`` is degenerate, after one line on stderr saying so.
"""

from __future__ import annotations

import argparse
import json
import sys

from agents.commands.arguments import CommandError, format_value, load_json_argument

__all__ = ["LOOP_PROBLEM", "add_arguments", "run"]

LOOP_PROBLEM = 3
"""Exit status of ``deadtime tune`` for an unstable, unconstrained or degenerate tuning."""

def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime tune``."""
    parser.add_argument("--rule", help="a rule name (see --list)")
    parser.add_argument("--plant", help="plant JSON as for analyze, or a file; default: the model is the plant")
    parser.add_argument("--model", help='identified model JSON {"type": "fopdt"|"sopdt"|"integrating", ...} or a file; '
                        "default: run the rule's experiments on the plant, noise free")
    parser.add_argument("--list", action="store_true", help="name every rule with its citation")
    parser.add_argument("--json", action="store_true", help='print one JSON object ("controller" is analyze\'s controller JSON)')


def run(args: argparse.Namespace) -> int:
    """Print the rule list (``--list``) or the tuning; :data:`LOOP_PROBLEM` if the loop has a problem."""
    from baselines.rules.tune import rule_list, tune
    from envs.identification.models import model_from_dict
    from envs.systems.plants import Plant

    if args.list:
        rules = rule_list()
        if args.json:
            print(json.dumps(rules))
        else:
            for rule in rules:
                print(f"{rule['name']:20s} {rule['controller']:10s} {rule['plants']:11s} {rule['citation']}")
        return 0
    if args.rule is None or (args.plant is None and args.model is None):
        raise CommandError("--rule and --plant or --model are required (or --list)")
    plant = None if args.plant is None else Plant.from_dict(load_json_argument(args.plant, "--plant"))
    model = None if args.model is None else model_from_dict(load_json_argument(args.model, "--model"))
    tuning = tune(args.rule, plant, model)
    result = tuning.to_dict()
    if args.json:
        print(json.dumps(result))
    else:
        print(f"{'rule':28s} {result['rule']}")
        print(f"{'citation':28s} {result['citation']}")
        print(f"{'parameter':28s} {format_value(result['parameter'])}")
        print(f"{'controller':28s} {json.dumps(result['controller'])}")
        for key, value in result["analysis"].items():
            print(f"{key:28s} {format_value(value)}")
    if result["problem"] is not None:
        print(f"deadtime tune: {result['problem']}", file=sys.stderr)
        return LOOP_PROBLEM
    return 0
