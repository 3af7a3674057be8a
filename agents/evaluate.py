"""``deadtime evaluate``: not built yet (see the open issues)."""

from __future__ import annotations

import argparse

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime evaluate``."""


def run(args: argparse.Namespace) -> int:
    raise ValueError("deadtime evaluate is not implemented yet")
