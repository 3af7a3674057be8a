"""``deadtime study NAME ...``: the research analyses of :mod:`agents.studies`, one subcommand each.

::

    deadtime study headline [--rl | --fixed | --own] [REGIMES_JSON]
    deadtime study certificates SWEEP...
    deadtime study gap SWEEP --env PID-v3 --group LABEL --rule simc-pi

What each computes: its module in :mod:`agents.studies`.  The command line only parses and calls.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Callable

__all__ = ["STUDIES", "add_arguments", "run"]


def _headline(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--rl", action="store_true", help="the RL agent in plan mode (default source results/rl_plan)")
    which.add_argument("--fixed", action="store_true", help="the fixed mode (default source results/fixed_mode_v3)")
    which.add_argument("--own", action="store_true", help="the plan chosen for the learned design (default results/own_plan)")
    parser.add_argument("regimes", nargs="?", type=Path, help="a regimes.json written by deadtime regimes")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.headline import tables

        which = "own" if args.own else "fixed" if args.fixed else "rl" if args.rl else "headline"
        return tables(which, args.regimes)
    return call


def _certificates(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("sweeps", type=Path, nargs="+", help="committed or finished sweep directories")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.certificates import table

        return table(args.sweeps)
    return call


def _gap(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("sweep", type=Path, help="a committed or finished sweep directory")
    parser.add_argument("--env", required=True, help="e.g. PID-v3")
    parser.add_argument("--group", required=True, help="the agent group's label")
    parser.add_argument("--rule", required=True, help="a rule of the sweep's baselines")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.gap import decompose, markdown

        return markdown(decompose(args.sweep, args.env, args.group, args.rule))
    return call


def _commit(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("source", type=Path, help="the finished sweep's output directory")
    parser.add_argument("target", type=Path, help="the directory to commit, under results/")

    def call(args: argparse.Namespace) -> None:
        from agents.studies.commit import commit

        commit(args.source, args.target)
    return call


def _fallback(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("run_dirs", type=Path, nargs="+", metavar="RUN_DIR", help="learned-rule fits, one per seed")
    parser.add_argument("--rule", default="simc-pi", help="the rule to fall back to (default simc-pi)")
    parser.add_argument("--safe", type=float, default=0.1, help="predicted violation probability below which the rule is safe")
    parser.add_argument("--out", type=Path, help="write DIR/fallback.md and DIR/fallback.json")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.fallback import fallback

        return fallback(args.run_dirs, args.rule, args.safe, args.out)
    return call


def _information(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("runs", nargs="+", type=Path, help="learned-rule fits with their cached training labels")
    parser.add_argument("--plants", type=int, default=600, help="validation plants (default 600)")
    parser.add_argument("--out", type=Path, default=Path("information.json"), help="the per-plant costs (resumable)")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.information import information

        return information(args.runs, args.plants, args.out)
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
                        help="where headroom.md/json and the costs' cache (work/) go, e.g. results/sequential")

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
                        help="a learner's runs, one per training seed, under a name")
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


def _procedures(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("runs", type=Path, help="the evaluations' directory (resumable)")
    parser.add_argument("out", type=Path, help="where procedures.md and per_plant_costs.csv.gz go")

    def call(args: argparse.Namespace) -> None:
        from agents.studies.procedures import procedures

        procedures(args.runs, args.out)
    return call


def _rescore(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("first", type=Path, help="the evaluation under the first version")
    parser.add_argument("second", type=Path, help="the same plants' evaluation under the second version")

    def call(args: argparse.Namespace) -> str:
        from agents.studies.rescore import table

        return table(args.first, args.second)
    return call


def _scaled_margin(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("run", type=Path, help="a learned rule's run directory (with its cached labels)")
    parser.add_argument("plants", type=int, help="how many validation plants to play")

    def call(args: argparse.Namespace) -> None:
        from agents.studies.scaled_margin import scaled_margin

        scaled_margin(args.run, args.plants)
    return call


def _experiment_length(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("noises", nargs="?", default="0.01,0.05,0.1,0.2", help="comma-separated noise levels")
    parser.add_argument("out", nargs="?", default="experiment_length.json", help="the rows (JSON)")
    parser.add_argument("oracle", nargs="?", default="", help="comma-separated policies whose oracle is computed")

    def call(args: argparse.Namespace) -> None:
        from agents.studies.experiment_length import experiment_length

        experiment_length([float(x) for x in args.noises.split(",")], args.out, {p for p in args.oracle.split(",") if p})
    return call


def _noise_kinds(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("kwargs", nargs="?", default="{}", help="environment arguments (JSON)")
    parser.add_argument("noises", nargs="?", default="0.01,0.05,0.1,0.2", help="comma-separated noise levels")
    parser.add_argument("--env", default="DeadTime/FPPI-v0")
    parser.add_argument("--rule", default="fppi-eq34")
    parser.add_argument("--no-oracle", action="store_true")
    parser.add_argument("--n", type=int, default=80)

    def call(args: argparse.Namespace) -> None:
        from agents.commands.arguments import load_json_argument
        from agents.studies.noise_kinds import noise_kinds

        noise_kinds(load_json_argument(args.kwargs, "--kwargs"), args.noises, args.env, args.rule, args.no_oracle, args.n)
    return call


def _no_arguments(module: str, function: str) -> Callable[[argparse.ArgumentParser], Callable]:
    def declare(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], None]:
        def call(args: argparse.Namespace) -> None:
            from importlib import import_module

            getattr(import_module(module), function)()
        return call
    return declare


def _violation_cost_plot(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], str | None]:
    parser.add_argument("path", nargs="?", default="docs/figures/violation_cost.png", help="the PNG to write")

    def call(args: argparse.Namespace) -> None:
        from agents.studies.violation_cost_plot import violation_cost_plot

        violation_cost_plot(args.path)
    return call


STUDIES: dict[str, tuple[str, Callable[[argparse.ArgumentParser], Callable[[argparse.Namespace], str | None]]]] = {
    "headline": ("the README's result tables from the committed regimes", _headline),
    "certificates": ("pooled test violation rates of learned groups, with exact intervals", _certificates),
    "gap": ("a group's difference to a rule, split by the rule's violating plants", _gap),
    "commit": ("copy a finished sweep into results/, compressed, and write its summary", _commit),
    "fallback": ("a learned design falling back to a rule where predicted safe, on validation plants", _fallback),
    "information": ("the learned rule with the true plant's parameters against the observation alone", _information),
    "headroom": ("what choosing the second experiment after the first could gain at most, on validation plants", _headroom),
    "sequential-replay": ("what a sequential agent does on validation plants, against the noise it measured",
                          _sequential_replay),
    "selector-choices": ("where a selector keeps the rule and where it overrides it, by normalized dead time",
                         _selector_choices),
    "transfer": ("learners tuned in simulation on the TCLab emulator under several conditions, against every rule",
                 _transfer),
    "procedures": ("the experiment procedures against the fixed procedure in the twelve regimes", _procedures),
    "rescore": ("two evaluations of the same plants under two versions, side by side", _rescore),
    "scaled-margin": ("a constant margin against a spread-scaled one, on validation plants", _scaled_margin),
    "experiment-length": ("the fixed procedure's experiment length against noise", _experiment_length),
    "steady-state": ("how far each experiment's true output is from its final value at its stop",
                     _no_arguments("agents.studies.steady_state", "steady_state")),
    "noise-kinds": ("experiment time, deviation and costs on the test plants under environment arguments", _noise_kinds),
    "commit-amplitude": ("the cost of committing at once at amplitude A in FPPI-v2's agent mode",
                         _no_arguments("agents.studies.commit_amplitude", "commit_amplitude")),
    "numba-dispatch": ("what numba's dispatch costs per fixed-mode episode",
                       _no_arguments("agents.studies.numba_dispatch", "numba_dispatch")),
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
