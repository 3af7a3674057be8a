"""``deadtime pretrain``: fit the shipped risk-conditioned learners again from their config.

Usage::

    deadtime pretrain [--config configs/risk_learner.yaml] [--structures PID,FPPI] [--labels DIR] [--models DIR]
                      [key=value ...]

Labels the config's training and validation plants (cached in ``--labels``, default
``runs/risk_learner/labels``; an interrupted run continues from the files written), chooses and fits
each structure's learner and writes ``learned-<structure>.skops`` and its manifest to ``--models``
(default the package's ``agents/pretrained``, the shipped files): :mod:`agents.risk.train`.
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
    parser.add_argument("overrides", nargs="*", metavar="key=value", help="config values, as YAML (training_plants=2000)")


def run(args: argparse.Namespace) -> int:
    """Fit and write the learners; print each manifest's path."""
    from agents.files.reader import load_yaml
    from agents.risk.config import load_config
    from agents.risk.pretrained import PRETRAINED_DIR
    from agents.risk.train import pretrain

    overrides = {}
    for item in args.overrides:
        key, equals, value = item.partition("=")
        if not equals or not key:
            raise ValueError(f"override {item!r} is not key=value")
        overrides[key] = load_yaml(value, key)
    config = load_config(args.config, overrides)
    structures = None if args.structures is None else tuple(s.strip().upper() for s in args.structures.split(","))
    if structures is not None:
        config = load_config(args.config, {**overrides, "structures": list(structures)})
    for path in pretrain(config, Path(args.labels), Path(args.models) if args.models else PRETRAINED_DIR, structures):
        print(path)
    return 0
