"""Analysis of a designed loop on the true plant: robustness (Nyquist stability, Ms, Mt, gain, phase
and delay margins; :mod:`.robustness`, compiled in :mod:`._robustness_kernels` over the
quasi-polynomial loop of :mod:`.loop_transfer`), the load and set-point IAE (:mod:`.performance`,
compiled in :mod:`._iae_kernels`), both together (:mod:`.loop_analysis`, ``deadtime analyze``) and
the episode's cost (:mod:`.scoring`).
"""

from envs._kernel_cache import refresh

refresh(__file__)  # before any kernel of the package is loaded (envs._kernel_cache)
