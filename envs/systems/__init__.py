"""The systems: plants ``G(s) e^{-Ls}`` (:mod:`.plants`; their coefficients :mod:`.coefficients`, their
state-space realization :mod:`.state_space`), the random plant families (:mod:`.families`, their
shapes :mod:`.shapes`) and the papers' benchmark batches (:mod:`.benchmark_batches`), the fixed
validation and test sets (:mod:`.plant_sets`), and the controllers (PID forms, FPPI, modified Smith
predictor) as blocks (:mod:`.controllers`).
"""

from envs._kernel_cache import refresh

refresh(__file__)  # before any kernel of the package is loaded (envs._kernel_cache)
