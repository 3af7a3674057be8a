"""Where an episode's plant comes from: a draw of the environment's family, or a plant given at reset.

Reads the arguments ``family`` and ``family_config`` (:class:`envs.env_config.EnvConfig`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from envs.systems.families import FAMILIES, check_family_config, sample_plant
from envs.systems.plants import Plant, as_plant

__all__ = ["FAMILY_KINDS", "PlantSource"]

FAMILY_KINDS: dict[str, bool] = {"stable": False, "fopdt": False, "sopdt": False, "lag-chain": False, "integrating": True}
"""The kind of plant each family of :mod:`envs.systems.families` draws (True: integrating), checked when the
environment is made; ``benchmark`` draws either, as its config says (a draw of the other kind is
drawn again)."""


class PlantSource:
    """The plants of an environment named ``owner`` whose plants integrate (``integrating``) or not.

    Parameters
    ----------
    family : str
        A family of :data:`envs.systems.families.FAMILIES` that draws plants of this kind (or ``benchmark``).
    family_config : object
        The family's config (:func:`envs.systems.families.check_family_config`).
    """

    def __init__(self, owner: str, integrating: bool, family: str, family_config: object = None) -> None:
        self.owner, self.integrating, self.family = owner, integrating, family
        if family not in FAMILIES:
            raise ValueError(f"unknown plant family {family!r}; valid families: {', '.join(FAMILIES)}")
        if family in FAMILY_KINDS and FAMILY_KINDS[family] != integrating:
            raise ValueError(self._wrong_family_kind(FAMILY_KINDS[family]))
        self.family_config = check_family_config(family, family_config)

    def draw(self, rng: np.random.Generator) -> Plant:
        """A plant of the family, drawn with ``rng``."""
        return sample_plant(self.family, rng, self.family_config)

    def given(self, plant: Any) -> Plant:
        """``reset``'s ``options["plant"]`` as a :class:`~envs.systems.plants.Plant` of this kind."""
        plant = as_plant(plant, "reset options: plant")
        if plant.integrating != self.integrating:
            kind = "an integrating" if self.integrating else "a self-regulating"
            raise ValueError(f"reset options: plant must be {kind} plant for {self.owner}")
        return plant

    def check_kind(self, plant: Plant) -> None:
        """Refuse a drawn plant of the other kind (a ``ValueError``: the plant is drawn again)."""
        if plant.integrating != self.integrating:
            raise ValueError(f"family {self.family!r} drew a plant of the wrong kind for {self.owner}")

    def _wrong_family_kind(self, integrating: bool) -> str:
        """The one line for a family of the other kind of plant than this environment's."""
        kinds = ("self-regulating", "integrating")
        fitting = [f for f, kind in FAMILY_KINDS.items() if kind == self.integrating] + ["benchmark"]
        return (f"family {self.family!r} draws {kinds[integrating]} plants; {self.owner} takes "
                f"{kinds[self.integrating]} plants (families: {', '.join(fitting)})")
