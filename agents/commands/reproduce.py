"""``deadtime reproduce``: the source papers' tables and figures (:mod:`baselines.reproduction.reproduce`)."""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime reproduce``."""
    parser.add_argument("name", help="a reproduction name, or 'all'")
    parser.add_argument("--json", action="store_true", help="print JSON (one object per reproduction)")
    parser.add_argument("--figures", default="figures", help="directory for the PNG figures (default: figures)")


def run(args: argparse.Namespace) -> int:
    """Print the reproductions named by ``args.name`` and write their figures."""
    from baselines.reproduction.reproduce import run_reproductions

    return run_reproductions(args.name, as_json=args.json, figures=Path(args.figures))
