"""The ``deadtime`` command line.

Each subcommand lives in the package that owns its concept and is imported only when it runs,
so that ``deadtime analyze`` never loads torch.  Bad input anywhere prints one line naming what is
wrong and exits with status 2; no traceback.  ``deadtime tune`` exits with status 3
(:data:`LOOP_PROBLEM`) when the rule's loop is unstable or outside the constraints on the plant,
or the rule's ``T_r`` is degenerate (:mod:`baselines.rules.tune`), after one line on stderr saying so.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from importlib import import_module
from typing import Any, Callable, Sequence

__all__ = ["main", "CommandError", "LOOP_PROBLEM", "load_json_argument"]

LOOP_PROBLEM = 3
"""Exit status of ``deadtime tune`` for an unstable, unconstrained or degenerate tuning."""


class CommandError(ValueError):
    """An error in the user's input, reported as one line."""


def load_json_argument(text: str, name: str) -> Any:
    """Parse ``text`` as JSON, or read it from a file if ``text`` is a path."""
    source = text
    if not text.lstrip().startswith(("{", "[")) and Path(text).is_file():
        source = Path(text).read_text()
    try:
        return json.loads(source)
    except json.JSONDecodeError as error:
        if source is text and not text.lstrip().startswith(("{", "[")):
            raise CommandError(f"{name}: no such file {text!r} (nor is it JSON)") from None
        raise CommandError(f"{name} is not valid JSON ({error.msg} at position {error.pos})") from None


def _analyze(args: argparse.Namespace) -> int:
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
            print(f"{key:28s} {_format(value)}")
    return 0


def _format(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if value is None:
        return "-"
    if isinstance(value, list):
        return ", ".join(_format(v) for v in value) or "-"
    return str(value)


def _tune(args: argparse.Namespace) -> int:
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
        print(f"{'parameter':28s} {_format(result['parameter'])}")
        print(f"{'controller':28s} {json.dumps(result['controller'])}")
        for key, value in result["analysis"].items():
            print(f"{key:28s} {_format(value)}")
    if result["problem"] is not None:
        print(f"deadtime tune: {result['problem']}", file=sys.stderr)
        return LOOP_PROBLEM
    return 0


def _reproduce(args: argparse.Namespace) -> int:
    from baselines.reproduction.reproduce import run_reproductions

    return run_reproductions(args.name, as_json=args.json, figures=Path(args.figures))


# Subcommands that own a module of ``agents``: the module defines ``add_arguments(parser)`` and
# ``run(args) -> int``, and imports its heavy dependencies (torch, stable-baselines3) inside ``run``.
_MODULE_COMMANDS: dict[str, tuple[str, str]] = {
    "train": ("agents.training.train", "train an agent from a YAML config"),
    "evaluate": ("agents.evaluation.evaluate", "evaluate policies (rules, oracle, agents) on held-out plants"),
    "bench": ("agents.bench.bench", "measure the speed and accuracy of the scoring and the environments"),
    "sweep": ("agents.sweeps.sweep", "train many seeds and configs on Ray Tune, evaluate them, and summarize"),
}


class _Parser(argparse.ArgumentParser):
    """argparse with usage errors reported as one line (exit status 2)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        sys.exit(2)


def _version() -> str:
    """The installed version of the ``deadtime-gym`` distribution (``pyproject.toml``)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("deadtime-gym")
    except PackageNotFoundError:
        return "unknown (not installed)"


def _parser() -> tuple[argparse.ArgumentParser, dict[str, Callable[[argparse.Namespace], int]]]:
    parser = _Parser(prog="deadtime", description="Tune controllers for dead-time processes.")
    parser.add_argument("--version", action="version", version=f"deadtime {_version()}")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    handlers: dict[str, Callable[[argparse.Namespace], int]] = {}

    analyze = commands.add_parser("analyze", help="robustness and IAE of a plant-controller loop")
    analyze.add_argument("--plant", required=True, help='JSON {"num": [...], "den": [...], "delay": L} or a file')
    analyze.add_argument("--controller", required=True, help='JSON {"type": "pid", "kp":, "ti":, "td":, "n":} etc. or a file')
    analyze.add_argument("--json", action="store_true", help="print one JSON object")
    handlers["analyze"] = _analyze

    tune = commands.add_parser(
        "tune", help="the controller an analytic rule gives for a plant, and its analysis",
        description="The controller an analytic rule gives for a plant or a model, and its analysis. Exit status 3 "
        "(after one line on stderr) when the loop is unstable or outside the constraints (Ms <= 2 except for the MSP, "
        "delay margin >= 0.2 L) on the plant, or the rule's T_r is degenerate (below its floor times L_n).")
    tune.add_argument("--rule", help="a rule name (see --list)")
    tune.add_argument("--plant", help="plant JSON as for analyze, or a file; default: the model is the plant")
    tune.add_argument("--model", help='identified model JSON {"type": "fopdt"|"sopdt"|"integrating", ...} or a file; '
                      "default: run the rule's experiments on the plant, noise free")
    tune.add_argument("--list", action="store_true", help="name every rule with its citation")
    tune.add_argument("--json", action="store_true", help='print one JSON object ("controller" is analyze\'s controller JSON)')
    handlers["tune"] = _tune

    reproduce = commands.add_parser("reproduce", help="the seeds' tables and figures beside their computed twins")
    reproduce.add_argument("name", help="a reproduction name, or 'all'")
    reproduce.add_argument("--json", action="store_true", help="print JSON (one object per reproduction)")
    reproduce.add_argument("--figures", default="figures", help="directory for the PNG figures (default: figures)")
    handlers["reproduce"] = _reproduce

    for name, (module_name, help_text) in _MODULE_COMMANDS.items():
        module = import_module(module_name)
        module.add_arguments(commands.add_parser(name, help=help_text, description=help_text))
        handlers[name] = module.run
    return parser, handlers


def shadowed_package() -> str | None:
    """One line if ``envs`` or ``baselines`` would be imported from elsewhere than beside ``agents``.

    The top-level names are fixed by the project's layout; a user's own ``envs/`` folder in the
    working directory or earlier on ``sys.path`` shadows ours (and ``gymnasium.make`` then fails
    with ``NamespaceNotFound: DeadTime``).
    """
    from importlib.util import find_spec

    root = Path(__file__).resolve().parents[1]
    for name in ("envs", "baselines"):
        spec = find_spec(name)
        locations = [] if spec is None else list(spec.submodule_search_locations or [])
        if not any(Path(location).resolve() == root / name for location in locations):
            found = ", ".join(locations) or "nowhere"
            return (f"the package {name!r} is imported from {found}, not from deadtime-gym's {root / name}: a folder "
                    f"named {name} in the working directory or on sys.path shadows ours; rename it or run elsewhere")
    return None


def main(argv: Sequence[str] | None = None) -> int:
    from agents.runtime import single_thread_defaults

    single_thread_defaults()  # before numpy is imported (agents.runtime)
    shadowed = shadowed_package()
    if shadowed is not None:
        print(f"deadtime: error: {shadowed}", file=sys.stderr)
        return 2
    parser, handlers = _parser()
    args = parser.parse_args(argv)
    try:
        return handlers[args.command](args)
    except (ValueError, OverflowError, OSError) as error:  # CommandError is a ValueError
        status = getattr(error, "exit_status", 2)
        print(f"deadtime {args.command}: {'error: ' if status == 2 else ''}{error}", file=sys.stderr)
        return status


if __name__ == "__main__":
    sys.exit(main())
