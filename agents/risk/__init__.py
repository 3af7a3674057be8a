"""The risk-conditioned learner: per structure, a design ``a(x, r)`` whose share of violating plants is at most ``r``.

:mod:`agents.risk.config` (its config), :mod:`agents.risk.labels` (the training and validation plants
labelled by the oracle's fast search), :mod:`agents.risk.model` (the regressions and the conformal
quantiles: the design), :mod:`agents.risk.pretrained` (the shipped models and their names,
``learned-pid@0.01``), :mod:`agents.risk.train` (one command that fits and writes them).
"""
