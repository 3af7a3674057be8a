"""``deadtime convert-model``: rewrite a model saved with pickles into files that load as data.

Usage::

    deadtime convert-model PATH --trust [--env ID]

``PATH`` is a learned rule's or a selector's run directory, or an agent's run directory or model
``.zip``.  Converting unpickles the old files, the one step that can run code from them: ``--trust``
is required, and says that whoever could write the folder is trusted.  ``--env`` names the
environment of an agent saved without its run's ``config.yaml``.  What is rewritten:
:mod:`agents.training.convert`.
"""

from __future__ import annotations

import argparse

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime convert-model``."""
    parser.add_argument("path", help="a learned rule's or selector's run directory, or an agent's run directory or .zip")
    parser.add_argument("--trust", action="store_true",
                        help="unpickle the old files (they can run any code): only for a folder you trust")
    parser.add_argument("--env", default=None, metavar="ID",
                        help="the environment of an agent saved without its run's config.yaml (its config is written)")


def run(args: argparse.Namespace) -> int:
    """Convert the model; print what was written and removed."""
    from agents.training.convert import convert

    for line in convert(args.path, args.trust, args.env):
        print(line)
    return 0
