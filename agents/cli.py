"""The ``deadtime`` command line: one table of subcommands, and :func:`main`.

Every subcommand is a module with ``add_arguments(parser)``, declaring its options, and
``run(args) -> int``, returning the exit status; the module imports its heavy dependencies (envs'
numerics, torch, stable-baselines3) inside ``run``, so that parsing loads none of them and
``deadtime analyze`` never loads torch.  Every such module lives in :mod:`agents.commands`, the one
place that knows the command line: the libraries it fronts (``envs``, ``baselines``, and
:mod:`agents.training`, :mod:`agents.evaluation`, :mod:`agents.bench`, :mod:`agents.sweeps`) take
plain arguments and never import argparse.

Bad input anywhere (a ``ValueError``, ``OverflowError`` or ``OSError``) prints one line naming what is
wrong and exits with status 2; no traceback.  Ctrl-C prints one line and exits with status 130
(:data:`INTERRUPTED`).  A reader of the standard output that has gone (``| head``) ends the command
quietly with status 141 (:data:`BROKEN_PIPE`).  An error with an ``exit_status`` attribute exits with
that status instead.  ``deadtime tune`` exits with status 3 (:data:`agents.commands.tune.LOOP_PROBLEM`)
when the rule's loop is unstable or outside the constraints on the plant, or the rule's ``T_r`` is
degenerate (:mod:`baselines.rules.tune`), after one line on stderr saying so.
"""

from __future__ import annotations

import argparse
import os
import sys
from importlib import import_module
from pathlib import Path
from typing import Callable, NamedTuple, Sequence

__all__ = ["BROKEN_PIPE", "COMMANDS", "Command", "INTERRUPTED", "main", "shadowed_package"]

INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT, as a shell reports a process it interrupted)."""

TERMINATED = 143
"""Exit status after SIGTERM (128 + SIGTERM), which ends a command as Ctrl-C does (:mod:`agents.interruptions`)."""

BROKEN_PIPE = 141
"""Exit status when the reader of the standard output has gone (128 + SIGPIPE, as a shell reports a
process that wrote into a closed pipe); nothing is printed."""


class Command(NamedTuple):
    """A subcommand: its module (``add_arguments``/``run``), its one-line help (``deadtime --help``) and
    its ``--help`` description (at least one sentence)."""

    module: str
    help: str
    description: str


def _described(module: str, text: str) -> Command:
    """A subcommand whose ``--help`` description is its one-line help, as a sentence."""
    return Command(module, text, f"{text[0].upper()}{text[1:]}.")


COMMANDS: dict[str, Command] = {
    "analyze": Command(
        "agents.commands.analyze", "robustness and IAE of a plant-controller loop",
        "The robustness (stability, Ms, Mt, gain, phase and delay margins) and the IAE of load and set-point "
        "responses of the loop of a plant and a controller, both given as JSON."),
    "tune": Command(
        "agents.commands.tune", "the controller an analytic rule gives for a plant, and its analysis",
        "The controller an analytic rule gives for a plant or a model, and its analysis. Exit status 3 "
        "(after one line on stderr) when the loop is unstable or outside the constraints (Ms <= 2 except for the MSP, "
        "delay margin >= 0.2 L) on the plant, or the rule's T_r is degenerate (below its floor times L_n)."),
    "reproduce": Command(
        "agents.commands.reproduce", "the source papers' tables and figures beside their computed twins",
        "Compute the source papers' tables and figures (one by name, or all) and print them beside the published "
        "values; the figures are written as PNG files."),
    "train": _described("agents.commands.train", "train an agent from a YAML config"),
    "evaluate": _described("agents.commands.evaluate", "evaluate policies (rules, oracle, agents) on held-out plants"),
    "bench": _described("agents.commands.bench", "measure the speed and accuracy of the scoring and the environments"),
    "sweep": _described("agents.commands.sweep", "train many seeds and configs on Ray Tune, evaluate them, and summarize"),
    "regimes": _described("agents.commands.regimes", "compare sweeps that differ only in their regime (env_kwargs): "
                          "costs, paired differences, a plot against one argument, what the agents do"),
    "protocol": _described("agents.commands.protocol", "a preregistered protocol: register its test seed, run it "
                           "(train, choose on validation, test once), report it, check its interval's coverage"),
    "frontier": _described("agents.commands.frontier", "any policy on a regime's frontier: mean cost against risk over "
                           "its knob on validation plants, the knob of least cost at each risk level"),
    "study": _described("agents.commands.study", "the research analyses behind the docs' numbers (deadtime study NAME --help)"),
    "convert-model": Command(
        "agents.commands.convert_model", "rewrite a model saved with pickles into files that load as data",
        "Rewrite a learned rule, a selector or an agent saved with pickles (older formats) into files that load "
        "without running code: a skops file, observation statistics as JSON, a manifest. It unpickles the old "
        "files, so it needs --trust."),
    "pretrain": _described("agents.commands.pretrain", "fit the shipped risk-conditioned learners (learned-pid@0.01, ...) "
                           "again from configs/risk_learner.yaml"),
    "process": Command(
        "agents.commands.process", "the procedure, the rules, the oracle and agents on a real process (the TCLab)",
        "Identify a sampled process (the TCLab emulator, or module:factory for your own) around its operating point, "
        "then test the commissioning controller, the rules, the process oracle and agents on the process itself; "
        "robustness on the identified model."),
}
"""The subcommands in the order ``deadtime --help`` lists them."""


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
    subparsers = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    handlers: dict[str, Callable[[argparse.Namespace], int]] = {}
    for name, command in COMMANDS.items():
        module = import_module(command.module)
        module.add_arguments(subparsers.add_parser(name, help=command.help, description=command.description))
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


def _reader_gone() -> int:
    """:data:`BROKEN_PIPE`, quietly, once the reader of the standard output has gone (``deadtime tune
    --list | head -2``): the rest of the output goes to ``os.devnull``, so that Python's final flush
    does not report the pipe again (the Python documentation's note on SIGPIPE)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # a standard output without a file descriptor (captured)
        pass
    return BROKEN_PIPE


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``deadtime`` with ``argv`` (default: ``sys.argv[1:]``) and return the exit status."""
    from agents.runtime import single_thread_defaults

    single_thread_defaults()  # before numpy is imported (agents.runtime)
    shadowed = shadowed_package()
    if shadowed is not None:
        print(f"deadtime: error: {shadowed}", file=sys.stderr)
        return 2
    parser, handlers = _parser()
    args = parser.parse_args(argv)
    from agents.interruptions import descendants, signals_as_interrupts

    earlier = descendants()
    try:
        with signals_as_interrupts():
            status = handlers[args.command](args)
            sys.stdout.flush()  # a reader gone (`| head`) shows here, not at exit
        return _ended(status, earlier)
    except BrokenPipeError:
        return _reader_gone()
    except BaseException as error:  # noqa: BLE001
        return _ended(_failed(args.command, error), earlier)


def _failed(command: str, error: BaseException) -> int:
    """The exit status of a command that raised ``error``, after one line on stderr; an error that is no
    input error nor an interruption is raised again (a traceback: a bug to report)."""
    from agents.interruptions import Terminated, ignore_interrupts, interrupted

    if interrupted(error):  # Ctrl-C, SIGTERM, or an error raised on their way out (numba, torch)
        with ignore_interrupts():  # a second Ctrl-C while the line is printed and children end
            print(f"\ndeadtime {command}: {'terminated' if isinstance(error, Terminated) else 'interrupted'}", file=sys.stderr)
        return TERMINATED if isinstance(error, Terminated) else INTERRUPTED
    if isinstance(error, ValueError | OverflowError | OSError):  # CommandError and FileProblem are ValueErrors
        status = getattr(error, "exit_status", 2)
        print(f"deadtime {command}: {'error: ' if status == 2 else ''}{error}", file=sys.stderr)
        return status
    raise error


def _ended(status: int, earlier: set[int]) -> int:
    """``status``, once every child process the command left is ended (none, unless it was interrupted:
    a pool's workers, multiprocessing's resource tracker, a local Ray cluster)."""
    if status in (INTERRUPTED, TERMINATED):
        from agents.interruptions import end_children, ignore_interrupts

        with ignore_interrupts():
            end_children(earlier)
    return status


if __name__ == "__main__":
    sys.exit(main())
