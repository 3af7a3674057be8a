"""Exact sampled simulation with dead times: linear systems with internal delays
(:mod:`.delay_systems`), their exact discretization (:mod:`.discretization`), runs of the discrete
systems (:mod:`.runs`, compiled sample by sample in :mod:`._run_kernels`), an open loop's response to
a held input (:mod:`.open_loop`), and plant-controller loops assembled as such systems and simulated
(:mod:`.loops`).
"""

from envs._kernel_cache import refresh

refresh(__file__)  # before any kernel of the package is loaded (envs._kernel_cache)
