"""``deadtime protocol``: a preregistered protocol's run, its report, its test seed and the interval's coverage.

::

    deadtime protocol register configs/protocols/v1.yaml          # its test seed, before any result
    deadtime protocol run configs/protocols/v1.yaml --out results/protocol_v1 --resume [--regime NAME ...] [--fits DIR]
    deadtime protocol report configs/protocols/v1.yaml --out results/protocol_v1
    deadtime protocol every-rule configs/protocols/v4.yaml --out results/protocol_v4   # each rule on the test plants
    deadtime protocol coverage --n 4000 --out results/protocol_coverage/coverage.json

``run`` trains, chooses on validation and tests regime after regime (:mod:`agents.protocol.run`);
each finished regime's folder can be committed as it finishes.  ``report`` writes
``protocol_results.json``, ``results.md`` and ``forest.png`` (:mod:`agents.protocol.report`).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the subcommands of ``deadtime protocol``."""
    actions = parser.add_subparsers(dest="action", required=True)
    register = actions.add_parser("register", help="register the protocol's test seed to its sha256")
    register.add_argument("protocol", help="the protocol file, e.g. configs/protocols/v1.yaml")
    run = actions.add_parser("run", help="train, choose on validation and test, regime after regime (resumable)")
    run.add_argument("protocol")
    run.add_argument("--out", required=True, help="the run's folder, e.g. results/protocol_v1")
    run.add_argument("--resume", action="store_true", help="continue a run of the same protocol in --out")
    run.add_argument("--regime", action="append", help="run only this regime (repeatable; default: all in order)")
    run.add_argument("--fits", help="the learners' fits (default OUT/work/runs); one folder shared by several protocols "
                                    "fits each learner they declare alike (environment, regime, config, overrides) once")
    run.add_argument("--validation-only", action="store_true",
                     help="stop each regime after its choices on the validation plants (selection.json), before its test")
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


def run(args: argparse.Namespace) -> int:
    """Run ``deadtime protocol ACTION``; bad input is a ValueError (one line, exit status 2)."""
    from agents.protocol.config import load_protocol

    if args.action == "coverage":
        from agents.protocol.coverage import coverage, levels

        result = coverage(Path(args.sweeps), args.n, args.replicates, levels(args.comparisons), args.seed)
        text = json.dumps(result, indent=1)
        if args.out:
            from agents.files.writer import write_text

            write_text(args.out, text + "\n")
            print(f"smallest coverage {result['smallest_coverage']} over {len(result['populations'])} populations; "
                  f"wrote {args.out}", file=sys.stderr)
        else:
            print(text)
        return 0
    protocol = load_protocol(args.protocol)
    if args.action == "register":
        from agents.protocol.streams import register_test_seed

        entry = register_test_seed(protocol.test.entropy, protocol.path, protocol.sha256,
                                   Path(protocol.path).with_name("test_seeds.json"))
        print(json.dumps(entry))
        return 0
    out = Path(args.out)
    if args.action == "run":
        from agents.protocol.run import run_protocol

        done = run_protocol(protocol, out, resume=args.resume, regimes=args.regime, validation_only=args.validation_only,
                            fits=Path(args.fits) if args.fits else None)
        print(f"deadtime protocol: {len(done)} regime(s) done: {', '.join(done)}", file=sys.stderr)
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
