"""The papers' tables and figures beside their computed twins, one module per paper.

* :mod:`~baselines.reproduction.common`: the :class:`Reproduction` and :class:`Row` results;
* :mod:`~baselines.reproduction.gorez_klan`: Gorez-Klan's model table (section 4) and mu table (section 3);
* :mod:`~baselines.reproduction.ingimundarson_tables`: Ingimundarson's Tables 1 and 2;
* :mod:`~baselines.reproduction.ingimundarson_figures`: Ingimundarson's Figures 6, 7 and 13;
* :mod:`~baselines.reproduction.delay_errors`: stability of the compensators under dead-time errors;
* :mod:`~baselines.reproduction.plots`: the PNG figures.

The registry and the command live in :mod:`baselines.reproduction.reproduce`.
"""

from baselines.reproduction.common import Reproduction, Row

__all__ = ["Reproduction", "Row"]
