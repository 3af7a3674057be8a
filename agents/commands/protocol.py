"""``deadtime protocol``: a preregistered protocol's run, its report, its test seed and the interval's coverage.

::

    deadtime protocol register configs/protocols/v1.yaml          # its test seed, before any result
    deadtime protocol run configs/protocols/v1.yaml --out results/protocol_v1 --resume [--regime NAME ...] [--fits DIR]
                                   [--workers N | --address HOST:PORT]
    deadtime protocol report configs/protocols/v1.yaml --out results/protocol_v1
    deadtime protocol every-rule configs/protocols/v4.yaml --out results/protocol_v4   # each rule on the test plants
    deadtime protocol coverage --n 4000 --out results/protocol_coverage/coverage.json
    deadtime protocol seeds-coverage results/protocol_v*/*/test_per_plant.csv.gz --seeds 20 --out FILE
    deadtime protocol frontier-cost DeadTime/PID-v3 [--plants N] [--fit RUN_DIR]   # one frontier task's CPU time
    deadtime protocol budget configs/protocols/v5.yaml --out results/protocol_v5 [--fits DIR] [--workers N]

``run`` trains, chooses on validation and tests (:mod:`agents.protocol.run`; a frontier protocol's
families by :mod:`agents.protocol.frontier_run`), from a tree whose code is the commit's (or, with
``--uncommitted-code``, marked so; :mod:`agents.protocol.code`), its fits and evaluations
as tasks in this process, on N local Ray workers or on a Ray cluster (:mod:`agents.protocol.workers`);
it holds a lock on ``--out`` while it runs, and Ctrl-C or SIGTERM ends it (status 130 or 143) with the
command that resumes; each finished regime's folder can be committed.  ``report`` writes
``protocol_results.json``, ``results.md`` and ``forest.png`` (:mod:`agents.protocol.report`; a frontier
protocol's ``protocol_results.json``, ``results.md`` and ``frontiers.png``: :mod:`agents.protocol.frontier_report`).
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
from pathlib import Path
from typing import Any

from agents.commands.arguments import require_directory

__all__ = ["CHUNK_PLANTS", "add_arguments", "run"]

CHUNK_PLANTS = 250
"""Plants per evaluation task by default (``--chunk-plants``); the tables do not depend on it."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the subcommands of ``deadtime protocol``."""
    actions = parser.add_subparsers(dest="action", required=True)
    register = actions.add_parser("register", help="register the protocol's test seed to its sha256")
    register.add_argument("protocol", help="the protocol file, e.g. configs/protocols/v1.yaml")
    run = actions.add_parser("run", help="train, choose on validation and test (resumable; in this process or on Ray)")
    run.add_argument("protocol")
    run.add_argument("--out", required=True, help="the run's folder, e.g. results/protocol_v1")
    run.add_argument("--resume", action="store_true", help="continue a run of the same protocol in --out (its finished fits "
                                                           "and evaluated plants kept)")
    run.add_argument("--regime", action="append", help="run only this regime (repeatable; default: all)")
    run.add_argument("--fits", help="the learners' fits (default OUT/work/runs); one folder shared by several protocols "
                                    "fits each learner they declare alike (environment, regime, config, overrides) once")
    run.add_argument("--validation-only", action="store_true",
                     help="stop each regime after its choices on the validation plants (selection.json), before its test")
    run.add_argument("--workers", type=int, default=1,
                     help="run the fits and the evaluations (chunks of plants) as tasks on a new local Ray instance of N "
                          "CPUs (default 1: one after another in this process, without Ray); the tables do not depend on it")
    run.add_argument("--chunk-plants", type=int, default=CHUNK_PLANTS,
                     help=f"plants per evaluation task (default {CHUNK_PLANTS}); the tables do not depend on it")
    run.add_argument("--address", help="run the tasks on the Ray cluster at this address (HOST:PORT, or auto) instead, as "
                                       "deadtime sweep does; every node needs this checkout at the same path and --out "
                                       "(and --fits) on a file system they all see")
    run.add_argument("--uncommitted-code", action="store_true",
                     help="run from a tree with changes not committed, or resume from another code than the run's "
                          "recorded hash, and mark protocol.json so (default: refused)")
    every = actions.add_parser("every-rule", help="every declared rule on the test plants of the regimes done, beside the "
                                                   "primaries (descriptive, outside the Holm family)")
    every.add_argument("protocol")
    every.add_argument("--out", required=True, help="the run's folder")
    every.add_argument("--regime", action="append", help="only this regime (repeatable; default: every regime tested)")
    report = actions.add_parser("report", help="protocol_results.json, results.md and forest.png of a run")
    report.add_argument("protocol")
    report.add_argument("--out", required=True)
    coverage = actions.add_parser("coverage", help="the coverage of the protocol's interval on the committed per-plant data")
    coverage.add_argument("--sweeps", default="results", help="the folder of the committed sweeps (default results)")
    coverage.add_argument("--n", type=int, default=4000, help="plants per replicate (default 4000, the test size)")
    coverage.add_argument("--replicates", type=int, default=4000, help="replicates per population (default 4000)")
    coverage.add_argument("--seed", type=int, default=0)
    coverage.add_argument("--comparisons", type=int, default=51,
                          help="Holm's family size m: the coverage is also checked at level 1 - 0.05/m (default 51, v1's)")
    coverage.add_argument("--out", help="write the JSON here (default: print it)")
    seeds = actions.add_parser("seeds-coverage", help="the coverage of the seeds-random interval on committed per-seed tables")
    seeds.add_argument("tables", nargs="+", help="per-plant tables (test_per_plant.csv.gz) of learners with several seeds")
    seeds.add_argument("--replicates", type=int, default=1000, help="replicates per population (default 1000)")
    seeds.add_argument("--seed", type=int, default=0)
    seeds.add_argument("--seeds", type=int, help="seeds drawn per replicate (default: the table's own count)")
    seeds.add_argument("--out", help="write the JSON here (default: print it)")
    cost = actions.add_parser("frontier-cost", help="the CPU time of one frontier evaluation per plant, and its "
                                                    "identification's share")
    cost.add_argument("env", help="the environment id, e.g. DeadTime/PID-v3")
    cost.add_argument("--plants", type=int, default=20, help="plants timed (default 20)")
    cost.add_argument("--env-kwargs", default="{}", help="environment options as JSON")
    cost.add_argument("--fit", help="a learned policy's run directory (its episode timed at knob 0.5)")
    spent = actions.add_parser("budget", help="a frontier protocol's compute from its run: CPU hours per regime, part "
                                              "and learner (agents/protocol/budget.py)")
    spent.add_argument("protocol", help="the protocol file, e.g. configs/protocols/v5.yaml")
    spent.add_argument("--out", required=True, help="the run's folder (its work/ holds the tasks' timings)")
    spent.add_argument("--fits", help="the learners' fits, if not OUT/work/runs")
    spent.add_argument("--workers", type=int, default=2, help="cores the wall time is given for (default 2)")
    spent.add_argument("--json", action="store_true", help="print the JSON instead of the markdown table")


def run(args: argparse.Namespace) -> int:
    """Run ``deadtime protocol ACTION``; bad input is a ValueError (one line, exit status 2)."""
    from agents.protocol.config import load_protocol

    if args.action in ("coverage", "seeds-coverage"):
        return _coverage(args)
    if args.action == "frontier-cost":
        from agents.commands.arguments import load_json_argument
        from agents.protocol.frontier_cost import measure

        if args.plants < 1:
            raise ValueError(f"--plants must be at least 1, got {args.plants}")
        print(json.dumps(measure(args.env, args.plants, load_json_argument(args.env_kwargs, "--env-kwargs"), args.fit), indent=1))
        return 0
    if args.action != "register":
        require_directory(args.out)  # before the protocol is read: the empty string would be the working directory
    if args.action == "budget":
        return _budget(args, load_protocol(args.protocol))
    protocol = load_protocol(args.protocol)
    if args.action == "register":
        from agents.protocol.streams import register_test_seed

        entry = register_test_seed(protocol.test.entropy, protocol.path, protocol.sha256,
                                   Path(protocol.path).with_name("test_seeds.json"))
        print(json.dumps(entry))
        return 0
    out = require_directory(args.out)
    if args.action == "run":
        return _run(args, protocol, out)
    if args.action == "every-rule" and protocol.frontier is not None:
        raise ValueError(f"{protocol.path} is a frontier protocol: every rule family is on its validation frontiers "
                         "(protocol_results.json), every-rule is for the protocols without a frontier")
    if args.action == "report" and protocol.frontier is not None:
        from agents.protocol.frontier_run import frontier_results

        from agents.protocol.frontier_report import write_frontier_report

        results = frontier_results(protocol, out)
        write_frontier_report(results, out, len(protocol.regimes))
        print(f"{len(results['regimes'])} of {len(protocol.regimes)} regime(s), {results['comparisons_in_holm_family']} "
              f"comparisons in the Holm family; wrote {out / 'protocol_results.json'}, results.md, frontiers.png", file=sys.stderr)
        return 0
    if args.action == "every-rule":
        from agents.protocol.every_rule import write_every_rule

        entries = write_every_rule(protocol, out, args.regime)
        print(f"every rule on the test plants of {len(entries)} regime(s); wrote {out / 'every_rule.md'}", file=sys.stderr)
        return 0
    from agents.protocol.report import write_report

    results = write_report(protocol, out)
    print(f"{results['comparisons_done']} of {results['comparisons_declared']} comparisons; wrote "
          f"{out / 'protocol_results.json'}, results.md, forest.png", file=sys.stderr)
    return 0


def _budget(args: argparse.Namespace, protocol: Any) -> int:
    """``deadtime protocol budget``: the run's compute, a markdown table per regime and part, then per learner (or
    ``--json``)."""
    from agents.protocol.budget import budget, budget_summary, budget_table

    if protocol.frontier is None:
        raise ValueError(f"{protocol.path} is not a frontier protocol: its tasks record no timings")
    if args.workers < 1:
        raise ValueError(f"--workers must be at least 1, got {args.workers}")
    out = require_directory(args.out)
    if not (out / "work").is_dir():
        raise ValueError(f"{out / 'work'} is missing: no run of {protocol.path} in --out")
    found = budget(protocol, out, Path(args.fits) if args.fits else None)
    if args.json:
        print(json.dumps(found, indent=1))
    else:
        print(budget_summary(found, args.workers) + "\n" + budget_table(found, args.workers), end="")
    return 0


def _coverage(args: argparse.Namespace) -> int:
    """``deadtime protocol coverage`` (the plants-random interval on the committed sweeps) or ``seeds-coverage``
    (the seeds-random one on committed per-seed tables): the JSON printed or written to ``--out``."""
    if args.action == "coverage":
        from agents.protocol.coverage import coverage, levels

        result = coverage(Path(args.sweeps), args.n, args.replicates, levels(args.comparisons), args.seed)
    else:
        from agents.protocol.seeds_coverage import seeds_coverage

        result = seeds_coverage(sorted(Path(table) for table in args.tables), args.replicates, 0.95, args.seed, args.seeds)
    text = json.dumps(result, indent=1)
    if args.out:
        from agents.files.writer import write_text

        write_text(args.out, text + "\n")
        print(f"smallest coverage {result['smallest_coverage']} over {len(result['populations'])} populations; "
              f"wrote {args.out}", file=sys.stderr)
    else:
        print(text)
    return 0


def _run(args: argparse.Namespace, protocol: Any, out: Path) -> int:
    """``deadtime protocol run``; Ctrl-C or SIGTERM ends it with status 130 or 143 and the command that resumes."""
    from agents.interruptions import ignore_interrupts, interrupted
    from agents.interruptions import terminated as was_terminated
    from agents.protocol.run import run_protocol

    if args.workers < 0 or args.chunk_plants < 1:
        raise ValueError(f"--workers must be >= 0 and --chunk-plants >= 1, got {args.workers} and {args.chunk_plants}")
    try:
        done = run_protocol(protocol, out, resume=args.resume, regimes=args.regime, validation_only=args.validation_only,
                            fits=Path(args.fits) if args.fits else None, workers=args.workers,
                            address=args.address or os.environ.get("RAY_ADDRESS"), chunk=args.chunk_plants,
                            uncommitted=True if args.uncommitted_code else None)
    except BaseException as error:  # noqa: BLE001  (an interruption, maybe wrapped by numba or torch, is said here)
        if not interrupted(error):
            raise
        terminated = was_terminated(error)
        with ignore_interrupts():  # a second signal while the line is printed shows no traceback
            print(f"\ndeadtime protocol: {'terminated' if terminated else 'interrupted'}; the finished fits and evaluated "
                  f"plants are kept in {out / 'work'}; continue with: {_resume_command(args)}", file=sys.stderr)
        return 143 if terminated else 130
    print(f"deadtime protocol: {len(done)} regime(s) done: {', '.join(done)}", file=sys.stderr)
    return 0


def _resume_command(args: argparse.Namespace) -> str:
    """The command that continues the interrupted run."""
    words = ["deadtime", "protocol", "run", args.protocol, "--out", args.out]
    words += [word for name in args.regime or [] for word in ("--regime", name)]
    words += ["--fits", args.fits] if args.fits else []
    words += ["--validation-only"] if args.validation_only else []
    words += ["--workers", str(args.workers)] if args.workers != 1 else []
    words += ["--chunk-plants", str(args.chunk_plants)] if args.chunk_plants != CHUNK_PLANTS else []
    words += ["--address", args.address] if args.address else []
    words += ["--uncommitted-code"] if args.uncommitted_code else []
    return shlex.join([*words, "--resume"])
