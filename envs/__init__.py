"""deadtime-gym environments: ``import envs`` registers them with Gymnasium.

The ids live in the ``DeadTime`` namespace (``gymnasium.make("DeadTime/PID-v0")``); the classes are
in :mod:`envs.tuning_env`, and the fixed mode's native vector environments (``gymnasium.make_vec``, the
``vector_entry_point``) in :mod:`envs.vector_env`: the only modules here that import Gymnasium besides
this registration.
The numerical subpackages, in the order of an episode, import numpy, scipy and numba only:
:mod:`envs.systems` (plants, families, controllers), :mod:`envs.simulation`,
:mod:`envs.identification` (experiments and models) and :mod:`envs.analysis` (margins, IAE, the
cost); then :mod:`envs.design`, :mod:`envs.episode` and the environments.
"""

from gymnasium.envs.registration import register

# v0: the design parameter on a log scale over its range (envs.structures.PARAMETER_RANGES).
# v1: the action is a residual around the structure's base rule, and the observation has the design
# features (envs.base_design); the plants, experiments and cost are v0's.
_V1 = {"action": "residual", "design_features": True}
# v2: v1 with experiments that have a price beyond their time: the production they disturb
# (weights.production, per unit of D_exp/T_ar) and an amplitude limit of 3 (agent mode); the fixed
# mode's experiments and the rules' inputs are v1's, its cost adds the production term.  Agent mode
# designs in a step of its own, after the commit has completed and shown the identification.
_V2 = {**_V1, "weights": {"production": 0.05}, "amplitude_limit": 3.0, "design_step": True}
# v3: v2 with a bounded violation cost (envs.analysis.scoring.violation_cost) and an observation made
# of the records only: the noise level estimated from them, failed experiments shown, and a commit that
# identifies nothing a failed experiment instead of an exception (envs.episode_options.EpisodeOptions);
# agent mode offers the experiments the structure's design reads (envs.episode_options.DESIGN_EXPERIMENTS).
_V3 = {**_V2, "violation_cost": "bounded", "measured_observation": True, "experiment_set": "design"}

# PI (SIMC PI, envs.structures): v3 only, the first version of that structure.
for _version, _kwargs, _structures in (("v0", {}, ("PID", "FPPI", "MSP")), ("v1", _V1, ("PID", "FPPI", "MSP")),
                                       ("v2", _V2, ("PID", "FPPI", "MSP")), ("v3", _V3, ("PID", "FPPI", "MSP", "PI"))):
    for _structure in _structures:
        register(id=f"DeadTime/{_structure}-{_version}", entry_point=f"envs.tuning_env:{_structure}Env",
                 vector_entry_point=f"envs.vector_env:{_structure}VectorEnv", kwargs=_kwargs)
