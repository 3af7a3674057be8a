"""``deadtime reproduce NAME|all``: the papers' tables and figures beside their computed twins.

Each registered reproduction is a function returning a frozen
:class:`~baselines.reproduction.common.Reproduction` (rows of case, quantity, paper value, computed
value; notes with the procedure and the reasons for every difference beyond the printed rounding;
an optional figure).  The modules of :mod:`baselines.reproduction` hold one paper each.

Output
------
* Human (default): per reproduction a table with the paper value, the computed value, the relative
  deviation ``(computed - paper)/|paper|`` and a mark ``off`` where the computed value does not
  round to the printed one (``ok`` where it does, blank for extras without a paper value), then
  the notes, then the path of the figure.
* ``--json``: one JSON object ``{"name", "rows": [{"case", "quantity", "paper", "computed"}],
  "notes": [...]}`` per reproduction, one per line (JSON Lines; for ``all`` in registry order).
  ``paper`` is ``null`` for extras; non-finite numbers are ``null``.  Figure paths go to stderr.

Figures are PNG files named ``<name>.png`` in the ``figures`` directory (created if needed).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Callable

from baselines.reproduction.common import Reproduction, relative_deviation, within_rounding
from baselines.reproduction.gorez_klan import gorez_klan_models, mu_robustness
from baselines.reproduction.ingimundarson_figures import fig6, fig7, fig13
from baselines.reproduction.ingimundarson_tables import table1, table2

__all__ = ["REPRODUCTIONS", "reproduce", "run_reproductions", "format_reproduction"]

REPRODUCTIONS: dict[str, Callable[[], Reproduction]] = {
    "gorez-klan-models": gorez_klan_models,
    "mu-robustness": mu_robustness,
    "ingimundarson-table1": table1,
    "ingimundarson-table2": table2,
    "ingimundarson-fig6": fig6,
    "ingimundarson-fig7": fig7,
    "ingimundarson-fig13": fig13,
}


def _names(name: str) -> list[str]:
    if name == "all":
        return list(REPRODUCTIONS)
    if name not in REPRODUCTIONS:
        raise ValueError(f"unknown reproduction {name!r}; valid names: all, {', '.join(REPRODUCTIONS)}")
    return [name]


def reproduce(name: str) -> Reproduction:
    """The reproduction registered under ``name`` (``ValueError`` naming the valid ones otherwise)."""
    return REPRODUCTIONS[_names(name)[0]]()


def _number(value: float | None) -> str:
    return "-" if value is None else f"{value:.5g}"


def format_reproduction(reproduction: Reproduction, figure: Path | None = None) -> str:
    """The human-readable table, notes and figure path of one reproduction."""
    header = ("case", "quantity", "paper", "computed", "rel. dev.", "rounding")
    body = []
    for row in reproduction.rows:
        deviation = relative_deviation(row)
        match = within_rounding(row)
        body.append((
            row.case,
            row.quantity,
            _number(row.paper),
            _number(row.computed),
            "-" if deviation is None else f"{100 * deviation:+.1f}%",
            "" if match is None else ("ok" if match else "off"),
        ))
    widths = [max(len(str(line[k])) for line in [header, *body]) for k in range(len(header))]
    lines = [f"== {reproduction.name}: {reproduction.title}"]
    for line in [header, *body]:
        lines.append("  ".join(str(cell).ljust(width) for cell, width in zip(line, widths)).rstrip())
    lines.append("notes:")
    lines += [f"  - {note}" for note in reproduction.notes]
    if figure is not None:
        lines.append(f"figure: {figure}")
    return "\n".join(lines)


def run_reproductions(name: str, as_json: bool = False, figures: Path = Path("figures")) -> int:
    """Compute and print the reproduction ``name`` (or ``"all"``); write its figures.

    Parameters
    ----------
    name : str
        A key of :data:`REPRODUCTIONS` or ``"all"``.
    as_json : bool
        Print JSON Lines instead of tables (see the module docstring).
    figures : Path
        Directory for the PNG figures.

    Returns
    -------
    int
        The exit code, 0.  Differences from the papers are results, not failures.

    Raises
    ------
    ValueError
        For an unknown name, listing the valid ones.
    """
    names = _names(name)
    for index, key in enumerate(names):
        reproduction = REPRODUCTIONS[key]()
        figure = reproduction.figure(Path(figures)) if reproduction.figure is not None else None
        if as_json:
            print(json.dumps(reproduction.to_dict()), flush=True)
            if figure is not None:
                print(f"figure: {figure}", file=sys.stderr)
        else:
            if index:
                print()
            print(format_reproduction(reproduction, figure), flush=True)
    return 0
