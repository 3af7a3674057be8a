"""Identification experiments on the true plant and the models read from them: the experiments'
common rules and results (:mod:`.experiment_base`), steady-state tests (:mod:`.steady_state`), the
commissioning PI (:mod:`.commissioning`), the closed-loop step, open-loop step/ramp/pulse and relay
experiments, their registry for agent mode (:mod:`.experiments`), the models and formulas
(:mod:`.models`: FOPDT, SOPDT, integrating; moments, eq. 11, 12, 22, 46) and the papers' fixed
identification procedure (:mod:`.procedure`).
"""
