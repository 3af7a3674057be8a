"""The optional settings of an episode's experiments, beyond those of the ``-v0`` environments.

:class:`EpisodeOptions` holds the environment arguments that change how an episode identifies its
plant; its defaults are exactly the ``-v0`` behaviour, so an environment made without them is
unchanged bit for bit (``tests/regression``).  The :class:`~envs.episode.Evidence` of an episode
carries its options, so that :func:`envs.episode.run_experiment`, :func:`envs.episode.features` and
:func:`envs.episode.identification` read them from it.

Each bad value raises one ``ValueError`` that names the environment argument.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["IDENTIFICATIONS", "EpisodeOptions", "DEFAULT_OPTIONS"]

IDENTIFICATIONS: tuple[str, ...] = ("seeds", "least-squares")
"""``identification`` values: the seeds' formulas (moments, areas), or the least-squares fit of
Marlin section 6.4 (:mod:`envs.identification.least_squares`) of the open-loop records."""

_ORDERS = {"pid": 2, "fppi": 1}  # the least-squares model each structure's design reads: SOPDT, FOPDT


@dataclass(frozen=True)
class EpisodeOptions:
    """Identification settings of an episode.

    Attributes
    ----------
    identification : {"seeds", "least-squares"}
        ``"least-squares"``: every open-loop step, PRBS and relay record is fitted by
        :func:`~envs.identification.least_squares.least_squares_fit` (instrumental variables, dead
        times up to the identified ``T_ar``), and the design reads the latest fit that gave a model;
        agent mode gains the experiment ``"prbs"``; three features are added (see
        :data:`envs.episode.LEAST_SQUARES_FEATURES`).
    order : {1, 2}
        Order of the least-squares model: 1 (FOPDT, the FPPI's model) or 2 (SOPDT, the PID's).
    """

    identification: str = "seeds"
    order: int = 1

    def __post_init__(self) -> None:
        if self.identification not in IDENTIFICATIONS:
            raise ValueError(f"identification must be one of {', '.join(IDENTIFICATIONS)}, got {self.identification!r}")
        if self.order not in (1, 2) or isinstance(self.order, bool):
            raise ValueError(f"order must be 1 or 2, got {self.order!r}")

    @property
    def least_squares(self) -> bool:
        return self.identification == "least-squares"

    @classmethod
    def for_structure(cls, structure: str, *, identification: str = "seeds") -> EpisodeOptions:
        """The options of an environment of ``structure`` (``"pid"``, ``"fppi"`` or ``"msp"``).

        Raises
        ------
        ValueError
            For a bad value, naming the argument; ``identification="least-squares"`` for the MSP
            (its plants integrate: the fits are FOPDT and SOPDT models).
        """
        if identification not in IDENTIFICATIONS:
            raise ValueError(f"identification must be one of {', '.join(IDENTIFICATIONS)}, got {identification!r}")
        if identification == "least-squares" and structure not in _ORDERS:
            raise ValueError("identification='least-squares' needs self-regulating plants (FOPDT and SOPDT fits); "
                             f"the {structure.upper()} environment's plants integrate")
        return cls(identification=identification, order=_ORDERS.get(structure, 1))


DEFAULT_OPTIONS = EpisodeOptions()
