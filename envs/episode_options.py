"""The optional settings of an episode's experiments, beyond those of the ``-v0`` environments.

:class:`EpisodeOptions` holds the environment arguments that change how an episode identifies its
plant; its defaults are exactly the ``-v0`` behaviour, so an environment made without them is
unchanged bit for bit (``tests/regression``).  The :class:`~envs.episode.Evidence` of an episode
carries its options, so that :func:`envs.episode.run_experiment`, :func:`envs.episode.features` and
:func:`envs.episode.identification` read them from it.

Each bad value raises one ``ValueError`` that names the environment argument.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from envs.env_config import ExperimentConfig
from envs.identification.disturbances import Disturbances
from envs.structures import STRUCTURES, structure as structure_named
from envs.validation import require_number

__all__ = ["AMPLITUDE_RANGE", "IDENTIFICATIONS", "EXPERIMENT_SETS", "DESIGN_EXPERIMENTS", "EpisodeOptions", "DEFAULT_OPTIONS"]

AMPLITUDE_RANGE = (0.1, 10.0)
"""The range of an agent-mode or plan-mode experiment amplitude (relative to a unit output change),
which the action's component in [-1, 1] covers on a log scale."""

IDENTIFICATIONS: tuple[str, ...] = ("seeds", "least-squares")
"""``identification`` values: the papers' formulas (moments, areas), or the least-squares fit of
Marlin section 6.4 (:mod:`envs.identification.least_squares`) of the open-loop records."""

EXPERIMENT_SETS: tuple[str, ...] = ("all", "design")
"""``experiment_set`` values: every experiment type of the plant's kind (v0-v2), or those whose result
the structure's design or design features read (:data:`DESIGN_EXPERIMENTS`; v3)."""

DESIGN_EXPERIMENTS: dict[str, tuple[str, ...]] = {name: s.design_experiments for name, s in STRUCTURES.items()}
"""The agent mode's experiment types with ``experiment_set="design"``
(:attr:`envs.structures.Structure.design_experiments`).  The closed-loop step gives
``K_n``, ``T_ar`` and the PID's SOPDT model (Gorez-Klan eq. 2-8) and the MSP's model (Ingimundarson
eq. 2); the open-loop step the FPPI's FOPDT model and mismatch area (eq. 11, 22) and the model the
PID's design features check against; the pulse the MSP's area (eq. 46); the relay the PID's ultimate
point (Astrom-Hagglund), the classical basis of a PID design.  The ramp only repeats the open-loop
step's ``T_n``, and no design reads a relay's result but the PID's: an agent offered them spent a
third to a half of its experiments on them.  ``identification="least-squares"`` adds the PRBS."""


@dataclass(frozen=True)
class EpisodeOptions:
    """Identification settings of an episode.

    Attributes
    ----------
    identification : {"seeds", "least-squares"}
        ``"least-squares"``: records are fitted by
        :func:`~envs.identification.least_squares.least_squares_fit` (instrumental variables, dead
        times up to the identified ``T_ar``): in fixed mode the fixed procedure's open-loop step, whose fit the
        design reads; in agent mode the new experiment ``"prbs"``, and the design reads the model of
        the latest experiment that gives one (a PRBS by least squares, or the papers' experiments by
        their formulas), so that the agent chooses the identification; three features are added
        (:data:`envs.episode.LEAST_SQUARES_FEATURES`).
    order : {1, 2}
        Order of the least-squares model: 1 (FOPDT, the FPPI's model) or 2 (SOPDT, the PID's).
    amplitude_limit : float
        The largest amplitude ``a`` an experiment may ask for (output units, > 0; default ``inf``):
        agent-mode amplitudes above it are cut to it, and the fixed procedure and the experiments
        a commit completes run at ``min(1, amplitude_limit)``.
    disturbances : Disturbances
        Drift and load in every experiment beyond the white noise (default none;
        :mod:`envs.identification.disturbances`).
    production : bool
        Whether the experiments' deviation ``D_exp`` is tracked (production has a price; the
        ``production`` weight of :class:`envs.analysis.scoring.CostWeights` is not 0).
    measured : bool
        The observation is made of the records only: the noise level is estimated from the
        closed-loop step's record (:func:`envs.identification.steady_state.noise_level`) for the
        noise-ratio feature and the relay's hysteresis, the experiments that gave nothing usable are a
        feature, and a commit whose identification fails is a failed experiment, not an exception
        (:mod:`envs.episode`).  Otherwise the configured noise level is read (the v0-v2 environments).
    experiment_types : tuple of str or None
        The agent mode's experiment types (``experiment_set="design"``: :data:`DESIGN_EXPERIMENTS`);
        None: every type of the plant's kind (:mod:`envs.episode`).
    noise_std : float
        The white measurement noise of every experiment, relative to a unit output change (the
        environments' ``noise_std``).
    quantization : float
        The sensor's resolution, in the units of ``noise_std`` (the environments' ``quantization``; 0:
        none): every experiment's measured output is floored to a multiple of it
        (:func:`envs.identification.noise.sensor_reading`), and the measured observation's noise
        estimate knows it (:func:`envs.identification.steady_state.quantized_noise_level`).
    """

    identification: str = "seeds"
    order: int = 1
    amplitude_limit: float = math.inf
    disturbances: Disturbances = field(default_factory=Disturbances)
    production: bool = False
    measured: bool = False
    experiment_types: tuple[str, ...] | None = None
    noise_std: float = 0.0
    quantization: float = 0.0

    def __post_init__(self) -> None:
        if self.identification not in IDENTIFICATIONS:
            raise ValueError(f"identification must be one of {', '.join(IDENTIFICATIONS)}, got {self.identification!r}")
        if self.order not in (1, 2) or isinstance(self.order, bool):
            raise ValueError(f"order must be 1 or 2, got {self.order!r}")

    @property
    def least_squares(self) -> bool:
        return self.identification == "least-squares"

    @property
    def seed_amplitude(self) -> float:
        """The amplitude of the fixed procedure's experiments: 1, or the amplitude limit if smaller."""
        return min(1.0, self.amplitude_limit)

    def limited(self, amplitude: float) -> float:
        """``amplitude`` cut to the amplitude limit."""
        return min(amplitude, self.amplitude_limit)

    @classmethod
    def from_config(cls, structure: str, config: ExperimentConfig, production: bool) -> EpisodeOptions:
        """The options of an environment of ``structure`` from its experiment arguments (:class:`envs.env_config.ExperimentConfig`;
        ``production``: the cost has a production weight)."""
        if not isinstance(config.measured_observation, bool):
            raise ValueError(f"measured_observation must be true or false, got {config.measured_observation!r}")
        return cls.for_structure(
            structure, noise_std=config.noise_std, identification=config.identification, amplitude_limit=config.amplitude_limit,
            disturbances=config.disturbances, production=production, measured=config.measured_observation,
            experiment_set=config.experiment_set, quantization=config.quantization,
        )  # fmt: skip

    @classmethod
    def for_structure(
        cls, structure: str, *, noise_std: float = 0.0, identification: str = "seeds", amplitude_limit: float | None = None,
        disturbances=None, production: bool = False, measured: bool = False, experiment_set: str = "all",
        quantization: float = 0.0,
    ) -> EpisodeOptions:  # fmt: skip
        """The options of an environment of ``structure`` (``"pid"``, ``"fppi"`` or ``"msp"``), from its
        arguments (``amplitude_limit=None`` is no limit; ``disturbances`` a mapping ``{kind: level}``).

        Raises
        ------
        ValueError
            For a bad value, naming the argument; ``identification="least-squares"`` or a ``load``
            disturbance for the MSP (its plants integrate: the fits are FOPDT and SOPDT models, and a
            lasting load makes the integral of the input grow without end).
        """
        if identification not in IDENTIFICATIONS:
            raise ValueError(f"identification must be one of {', '.join(IDENTIFICATIONS)}, got {identification!r}")
        kind = structure_named(structure)
        if identification == "least-squares" and kind.least_squares_order is None:
            raise ValueError("identification='least-squares' needs self-regulating plants (FOPDT and SOPDT fits); "
                             f"the {structure.upper()} environment's plants integrate")
        limit = math.inf if amplitude_limit is None else require_number(amplitude_limit, "amplitude_limit", positive=True)
        found = Disturbances.from_argument(disturbances, "disturbances")
        if found.load > 0 and kind.integrating:
            raise ValueError("disturbances['load'] needs self-regulating plants: under a lasting load the integral of "
                             f"the input of the {structure.upper()} environment's integrating plants grows without end, "
                             "and the closed-loop step identifies no model")
        if experiment_set not in EXPERIMENT_SETS:
            raise ValueError(f"experiment_set must be one of {', '.join(EXPERIMENT_SETS)}, got {experiment_set!r}")
        types = None
        if experiment_set == "design":
            types = kind.design_experiments + (("prbs",) if identification == "least-squares" else ())
        return cls(identification=identification, order=kind.least_squares_order or 1, amplitude_limit=limit,
                   disturbances=found, production=bool(production), measured=bool(measured), experiment_types=types,
                   noise_std=require_number(noise_std, "noise_std", nonnegative=True),
                   quantization=require_number(quantization, "quantization", nonnegative=True))


DEFAULT_OPTIONS = EpisodeOptions()
