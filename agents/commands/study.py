"""``deadtime study NAME ...``: the research analyses of :mod:`agents.studies`, one subcommand each.

::

    deadtime study commit runs/NAME results/exploratory/NAME
    deadtime study headroom [--protocol configs/protocols/v1.yaml] [--design base|oracle|learned]
    deadtime study selector-choices configs/protocols/v3.yaml results/protocol_v3 REGIME... --out DIR

What each computes: its module in :mod:`agents.studies`.  The command line only parses and calls.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Callable

__all__ = ["STUDIES", "add_arguments", "run"]


def _commit(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("source", type=Path, help="the finished sweep's output directory")
    parser.add_argument("target", type=Path, help="the directory to commit, under results/")

    def call(args: argparse.Namespace) -> None:
        from agents.studies.commit import commit

        commit(args.source, args.target)
    return call


def _headroom(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("--protocol", type=Path, default=Path("configs/protocols/v1.yaml"),
                        help="the protocol whose validation plants and regimes are used (default v1)")
    parser.add_argument("--plants", type=int, default=2000, help="validation plants per regime (default 2000)")
    parser.add_argument("--replicates", type=int, default=4, help="noise draws of each continuation (default 4, even)")
    parser.add_argument("--design", choices=("base", "oracle", "learned"), default="base",
                        help="the design of every episode: the base rule (default), the per-episode oracle, or the "
                             "learned designs of --fits")
    parser.add_argument("--fits", nargs="+", type=Path, default=[], metavar="RUN_DIR",
                        help="--design learned: learned-rule fits of fixed plans [A1, A2], one per second amplitude")
    parser.add_argument("--agents", nargs="+", type=Path, default=[], metavar="RUN_DIR",
                        help="--design learned: sequential agents (one run per seed) played on the same plants")
    parser.add_argument("--training-plants", type=int, default=0,
                        help="--design learned: train the learned continuation on this many plants of its own stream")
    parser.add_argument("--out", type=Path, required=True,
                        help="where headroom.md/json and the costs' cache (work/) go, e.g. results/exploratory/sequential")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.headroom import headroom

        if args.design == "learned":
            from agents.studies.learned_headroom import learned_headroom

            if not args.fits:
                raise ValueError("--design learned needs --fits RUN_DIR ... (learned-rule fits of fixed plans)")
            return learned_headroom(args.protocol, args.fits, args.plants, args.replicates, args.out, args.agents,
                                    args.training_plants)
        return headroom(args.protocol, args.plants, args.replicates, args.out, args.design)
    return call


def _sequential_replay(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("runs", nargs="+", type=Path, metavar="RUN_DIR", help="agents of the discrete agent mode")
    parser.add_argument("--plants", type=int, default=500, help="validation plants (default 500)")
    parser.add_argument("--out", type=Path, help="write DIR/replay.md, replay.json and replay.png")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.sequential_replay import replay

        return replay(args.runs, args.plants, args.out)
    return call


def _selector_choices(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("protocol", type=Path, help="the protocol file, e.g. configs/protocols/v3.yaml")
    parser.add_argument("run_dir", type=Path, help="its run folder, with the work/ the run left (e.g. results/protocol_v3)")
    parser.add_argument("regimes", nargs="+", help="regimes whose validation holds a selector")
    parser.add_argument("--out", type=Path, help="write DIR/choices.md, choices.json and choices.png")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.selector_choices import choices

        return choices(args.protocol, args.run_dir, args.regimes, args.out)
    return call


def _transfer(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("groups", nargs="+", metavar="GROUP=RUN_DIR,...",
                        help="a learner's runs, one per training seed, under a name; or a shipped learner at a risk "
                             "(NAME=learned-pid@0.01)")
    parser.add_argument("--seeds", type=int, default=3, help="emulator seeds per condition (default 3, at least 2)")
    parser.add_argument("--out", type=Path, help="write DIR/transfer.md, transfer.json and transfer.png")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.transfer import transfer

        groups = {}
        for item in args.groups:
            name, _, runs = item.partition("=")
            if not name or not runs:
                raise ValueError(f"a group must be NAME=RUN_DIR,RUN_DIR,..., got {item!r}")
            groups[name] = runs.split(",")
        return transfer(groups, args.seeds, args.out)
    return call


def _numba_dispatch(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("--slots", type=int, default=32, help="episodes played at once (default 32)")
    parser.add_argument("--rounds", type=int, default=2, help="batches recorded (default 2)")
    parser.add_argument("--calls", type=int, default=2000, help="timed calls per kernel (default 2000)")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.numba_dispatch import numba_dispatch

        return numba_dispatch(args.slots, args.rounds, args.calls)
    return call


def _violation_cost_plot(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("path", nargs="?", default="docs/figures/violation_cost.png", help="the PNG to write")

    def call(args: argparse.Namespace) -> None:
        from agents.studies.violation_cost_plot import violation_cost_plot

        violation_cost_plot(args.path)
    return call


STUDIES: dict[str, tuple[str, Callable[[argparse.ArgumentParser], Callable[[argparse.Namespace], str | None]]]] = {
    "commit": ("copy a finished sweep into results/, compressed, and write its summary", _commit),
    "headroom": ("what choosing the second experiment after the first could gain at most, on validation plants", _headroom),
    "sequential-replay": ("what a sequential agent does on validation plants, against the noise it measured",
                          _sequential_replay),
    "selector-choices": ("where a selector keeps the rule and where it overrides it, by normalized dead time",
                         _selector_choices),
    "transfer": ("learners tuned in simulation on the TCLab emulator under several conditions, against every rule",
                 _transfer),
    "numba-dispatch": ("what numba's dispatch costs per fixed-mode episode", _numba_dispatch),
    "violation-cost-plot": ("the figure of docs/scoring.md: a violating design's cost against its grade", _violation_cost_plot),
}
"""Each study's one-line help and the function that declares its arguments and returns its call."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare ``deadtime study NAME`` and each study's options."""
    studies = parser.add_subparsers(dest="study", required=True, metavar="NAME", parser_class=type(parser))
    for name, (text, declare) in STUDIES.items():
        sub = studies.add_parser(name, help=text, description=f"{text[0].upper()}{text[1:]}.")
        sub.set_defaults(study_call=declare(sub))


def run(args: argparse.Namespace) -> int:
    """Run the study; a returned text is printed."""
    text = args.study_call(args)
    if text is not None:
        print(text)
    return 0
