"""Scoring policies (rules, oracle, agents) on held-out plants (``deadtime evaluate``): the command
(:mod:`.evaluate`), the policies (:mod:`.policies`), the per-plant runs and their cache (:mod:`.run`),
the statistics, tables and plots, the statistics over seeds (:mod:`.seed_statistics`), and the
wrapper that adds the oracle's cost to an episode's final ``info`` (:mod:`.oracle_info`).
"""
