"""``deadtime analyze``: robustness and IAE of a plant-controller loop (:func:`envs.analysis.loop_analysis.analyze`)."""

from __future__ import annotations

import argparse
import json

from agents.commands.arguments import PLANT_COEFFICIENTS, format_value, load_json_argument

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime analyze``."""
    parser.add_argument("--plant", required=True, help='JSON {"num": [...], "den": [...], "delay": L} or a file; at most '
                        f'{PLANT_COEFFICIENTS} coefficients in num and in den')
    parser.add_argument("--controller", required=True, help='JSON {"type": "pid", "kp":, "ti":, "td":, "n":} etc. or a file')
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def run(args: argparse.Namespace) -> int:
    """Print the analysis of the loop, one figure per line or one JSON object (``--json``)."""
    from envs.analysis.loop_analysis import analyze
    from envs.systems.controllers import controller_from_dict
    from envs.systems.plants import Plant

    plant = Plant.from_dict(load_json_argument(args.plant, "--plant"))
    controller = controller_from_dict(load_json_argument(args.controller, "--controller"))
    result = analyze(plant, controller).to_dict()
    if args.json:
        print(json.dumps(result))
    else:
        for key, value in result.items():
            print(f"{key:28s} {format_value(value)}")
    return 0
