"""``deadtime pretrain``: fit the shipped risk-conditioned learners again from their config.

Usage::

    deadtime pretrain [--config configs/risk_learner.yaml] [--structures PID,FPPI] [--labels DIR] [--models DIR]
                      [key=value ...]
    deadtime pretrain --report [--structures PID,FPPI] [--plants 2000] [--out results/exploratory/risk_learner] [--cached]
    deadtime pretrain --report --frontiers runs/frontier [--out results/exploratory/risk_learner]

Labels the config's training and validation plants (cached in ``--labels``, default
``runs/risk_learner/labels``; an interrupted run continues from the files written), chooses and fits
each structure's learner and writes ``learned-<structure>.skops`` and its manifest to ``--models``
(default the package's ``agents/pretrained``, the shipped files): :mod:`agents.risk.train`.  With
``--report`` it fits nothing: it plays the learners on validation plants and writes the calibration
tables (:mod:`agents.risk.report`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime pretrain``."""
    parser.add_argument("--config", default="configs/risk_learner.yaml", help="the learners' YAML config")
    parser.add_argument("--structures", default=None, help="comma-separated structures (default: the config's)")
    parser.add_argument("--labels", default="runs/risk_learner/labels", help="the folder of the cached labels")
    parser.add_argument("--models", default=None, help="where the model files go (default: the package's agents/pretrained)")
    parser.add_argument("--report", action="store_true", help="fit nothing: play the learners on validation plants and "
                                                                  "write the calibration tables to --out")
    parser.add_argument("--plants", type=int, default=2000, help="validation plants per structure and regime of --report")
    parser.add_argument("--out", default="results/exploratory/risk_learner", help="the folder of --report's tables")
    parser.add_argument("--frontiers", help="with --report: also comparison.md from the frontier.json of each folder in this one "
                                            "(deadtime frontier's results)")
    parser.add_argument("--cached", action="store_true", help="--report plays nothing: the tables of the plants played so far")
    parser.add_argument("overrides", nargs="*", metavar="key=value", help="config values, as YAML (training_plants=2000)")


def run(args: argparse.Namespace) -> int:
    """Fit and write the learners; print each manifest's path."""
    from agents.files.reader import load_yaml
    from agents.risk.config import load_config
    from agents.risk.pretrained import PRETRAINED_DIR
    from agents.risk.train import pretrain

    models = Path(args.models) if args.models else None
    overrides = {}
    for item in args.overrides:
        key, equals, value = item.partition("=")
        if not equals or not key:
            raise ValueError(f"override {item!r} is not key=value")
        overrides[key] = load_yaml(value, key)
    if args.report:
        from agents.risk.report import write_matched, write_report

        if args.frontiers:
            folders = sorted(path.parent for path in Path(args.frontiers).glob("*/frontier.json"))
            if not folders:
                raise ValueError(f"--frontiers: no frontier.json in the folders of {args.frontiers}")
            print(f"wrote {write_matched(folders, Path(args.out))}")
            return 0
        chosen = (args.structures or "PID,FPPI,MSP,PI").upper().split(",")
        written = write_report(args.config, [s.strip() for s in chosen], args.plants, Path(args.out), models, args.cached,
                               Path(args.labels))
        print(f"wrote {written}")
        return 0
    config = load_config(args.config, overrides)
    structures = None if args.structures is None else tuple(s.strip().upper() for s in args.structures.split(","))
    unknown = sorted(set(structures or ()) - set(config.structures))
    if unknown:
        raise ValueError(f"--structures: {', '.join(unknown)} not among the config's {', '.join(config.structures)}")
    for path in pretrain(config, Path(args.labels), models or PRETRAINED_DIR, structures):
        print(path)
    return 0
