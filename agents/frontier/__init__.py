"""Every policy a one-parameter family by its risk knob, and its frontier of cost against risk.

:mod:`~agents.frontier.families` (the knob of a learned policy, an agent and a selector; a rule's is
:mod:`baselines.rules.family`), :mod:`~agents.frontier.frontier` (cost and risk over the knob on a
regime's validation plants, the knob chosen per risk level), :mod:`~agents.frontier.statistics`
(intervals with seeds and plants random, and their coverage by simulation); docs/frontier.md.
"""
