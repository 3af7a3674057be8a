"""The research analyses behind the numbers of README.md and docs/, as functions of plain arguments
(``deadtime study NAME``, whose command line is :mod:`agents.commands.study`).

On the committed results (``results/``, read in place through :mod:`agents.compressed`):
:mod:`.headline` (the README's result tables), :mod:`.certificates` (pooled test violation rates of
certified groups), :mod:`.gap` (a difference to a rule split by the rule's violating plants),
:mod:`.commit` (a finished sweep copied into ``results/``).  Studies that play episodes or fits:
:mod:`.fallback` (a learned design falling back to a rule), :mod:`.information` (the learned rule with
the true plant's parameters), :mod:`.procedures` (the experiment procedures against the fixed one),
:mod:`.rescore` (two versions' scores of the same plants), :mod:`.scaled_margin`,
:mod:`.experiment_length`, :mod:`.steady_state`, :mod:`.noise_kinds`, :mod:`.commit_amplitude`,
:mod:`.numba_dispatch` (what numba's dispatch costs per episode) and :mod:`.violation_cost_plot` (the
figure of docs/scoring.md).  Each module's docstring says what it computes and which page quotes it.
"""
