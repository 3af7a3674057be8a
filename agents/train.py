"""``deadtime train``: not built yet (see the open issues)."""

from __future__ import annotations

import argparse

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime train``."""


def run(args: argparse.Namespace) -> int:
    raise ValueError("deadtime train is not implemented yet")
