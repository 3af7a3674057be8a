"""A preregistered protocol: regimes, plant streams, choices on validation, one test, statistics that hold.

One concept per module: :mod:`~agents.protocol.config` (the protocol file), :mod:`~agents.protocol.streams`
(plant streams and the registry of test seeds), :mod:`~agents.protocol.training` (the learners' fits),
:mod:`~agents.protocol.selection` (choices on the validation plants), :mod:`~agents.protocol.statistics`
(plant-clustered violations, paired differences, Holm), :mod:`~agents.protocol.run` (``deadtime protocol
run``), :mod:`~agents.protocol.tasks` (its fits and evaluations as tasks), :mod:`~agents.protocol.workers`
(where they run: this process or Ray), :mod:`~agents.protocol.report` (``protocol_results.json``, the verdict table, the forest plot) and
:mod:`~agents.protocol.coverage` (the interval's coverage by simulation).
"""
