"""Identification experiments on the true plant and the models read from them: the experiments'
common rules and results (:mod:`.experiment_base`), steady-state tests (:mod:`.steady_state`), the
commissioning PI (:mod:`.commissioning`), the closed-loop step, open-loop step/ramp/pulse and relay
experiments, their registry for agent mode (:mod:`.experiments`), the models (:mod:`.models`:
FOPDT, SOPDT, integrating), the formulas that read them off sampled signals (:mod:`.moments`,
:mod:`.open_loop_areas`: eq. 11, 12, 22, 46; :mod:`.reaction_curve`; :mod:`.least_squares` over the
difference equations of :mod:`.difference_equation`; the trapezoids of :mod:`.sampled_signals`) and
the papers' fixed identification procedure (:mod:`.procedure`).
"""

from envs._kernel_cache import refresh

refresh(__file__)  # before any kernel of the package is loaded (envs._kernel_cache)
