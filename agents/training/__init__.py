"""Training stable-baselines3 agents from configs (``deadtime train``): the config schema
(:mod:`.config`, :mod:`.hyperparameters`), the run (:mod:`.train`), its callbacks, checkpoints,
signal handling and atomic files, and loading a saved agent with its normalization (:mod:`.policies`).
"""
