"""Exact sampled simulation with dead times: linear systems with internal delays and their exact
discretization (:mod:`.delay_systems`), their compiled sample-by-sample runs (:mod:`._run_kernels`),
and plant-controller loops assembled as such systems and simulated (:mod:`.loops`).
"""
