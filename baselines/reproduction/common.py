"""The result types of a reproduction and small shared helpers.

A :class:`Reproduction` pairs every number a paper prints (a table cell, or a number the text
states about a figure) with its computed twin, as :class:`Row` objects, and says in ``notes``
why they differ wherever they differ beyond the printed rounding.  ``figure`` draws the computed
figure, if any, as a PNG.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

__all__ = ["Row", "Reproduction", "printed", "printed_decimals", "within_rounding", "relative_deviation"]


@dataclass(frozen=True)
class Row:
    """One printed number beside its computed twin.

    Attributes
    ----------
    case : str
        The row of the paper's table, or the situation a statement is about (``"P3"``,
        ``"T_r/L_n = 0.01"``).
    quantity : str
        What is compared, with the paper's symbol and equation (``"T_n (eq. 11)"``).
    paper : float or None
        The printed value; ``None`` for a computed extra that the paper does not print (a
        cross-check, or a figure read only qualitatively).
    computed : float
        The value computed here.
    decimals : int or None
        Decimals printed in the paper (for the rounding test); ``None`` if ``paper`` is None.
    """

    case: str
    quantity: str
    paper: float | None
    computed: float
    decimals: int | None = None

    def to_dict(self) -> dict[str, object]:
        """``{"case", "quantity", "paper", "computed"}`` (non-finite numbers become ``None``)."""

        def number(value: float | None) -> float | None:
            return float(value) if value is not None and math.isfinite(value) else None

        return {"case": self.case, "quantity": self.quantity, "paper": number(self.paper), "computed": number(self.computed)}


def printed(case: str, quantity: str, paper: str | None, computed: float) -> Row:
    """A :class:`Row` whose paper value is given as printed (``"0.27"``), keeping its decimals."""
    if paper is None:
        return Row(case, quantity, None, float(computed))
    return Row(case, quantity, float(paper), float(computed), printed_decimals(paper))


def printed_decimals(text: str) -> int:
    """Number of decimals in a printed number: ``"0.27"`` -> 2, ``"6"`` -> 0."""
    return len(text.split(".")[1]) if "." in text else 0


def within_rounding(row: Row) -> bool | None:
    """Whether ``computed`` rounds to the printed value: ``|computed - paper| <= 0.5 10^-decimals``.

    A relative slack of ``1e-9`` absorbs binary representation of the printed decimals.
    ``None`` for rows without a paper value.
    """
    if row.paper is None or row.decimals is None:
        return None
    half_unit = 0.5 * 10.0 ** (-row.decimals)
    return abs(row.computed - row.paper) <= half_unit * (1 + 1e-9)


def relative_deviation(row: Row) -> float | None:
    """``(computed - paper)/|paper|``; ``None`` without a paper value or for ``paper == 0``."""
    if row.paper is None or row.paper == 0:
        return None
    return (row.computed - row.paper) / abs(row.paper)


@dataclass(frozen=True)
class Reproduction:
    """A paper's table or figure beside its computed twin.

    Attributes
    ----------
    name : str
        Registry name (``"ingimundarson-table1"``).
    title : str
        The source: paper, section, table or figure.
    rows : tuple of Row
        Paper value against computed value.
    notes : tuple of str
        The procedure used, and a reason for every row outside the printed rounding.
    figure : callable or None
        ``figure(directory) -> path``: draws the computed figure into ``directory`` as a PNG and
        returns its path.
    """

    name: str
    title: str
    rows: tuple[Row, ...]
    notes: tuple[str, ...]
    figure: Callable[[Path], Path] | None = field(default=None, compare=False)

    def row(self, case: str, quantity: str) -> Row:
        """The row with this case and quantity (``KeyError`` if there is none)."""
        for row in self.rows:
            if row.case == case and row.quantity == quantity:
                return row
        raise KeyError(f"{self.name} has no row ({case!r}, {quantity!r})")

    def to_dict(self) -> dict[str, object]:
        """``{"name", "rows": [...], "notes": [...]}`` as printed by ``deadtime reproduce --json``."""
        return {"name": self.name, "rows": [row.to_dict() for row in self.rows], "notes": list(self.notes)}
