"""The research analyses behind the numbers of docs/, as functions of plain arguments
(``deadtime study NAME``, whose command line is :mod:`agents.commands.study`).

:mod:`.commit` (a finished sweep copied into ``results/``), :mod:`.headroom` with
:mod:`.learned_headroom` and :mod:`.continuation` (what choosing the second experiment after the first
could gain, docs/sequential.md), :mod:`.sequential_replay` (what a sequential agent does),
:mod:`.selector_choices` (where a selector overrides its rule, docs/selector.md), :mod:`.transfer`
(learners on the TCLab emulator, docs/real_process.md), :mod:`.numba_dispatch` (what numba's dispatch
costs per episode, docs/performance.md) and :mod:`.violation_cost_plot` (the figure of docs/scoring.md).
Each module's docstring says what it computes and which page quotes it.  The retired studies and the
commits of their outputs are listed in docs/results.md.
"""
