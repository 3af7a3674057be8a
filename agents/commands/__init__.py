"""The ``deadtime`` subcommands: the command line, and nothing else, of the functions they front.

One module per subcommand, each following the protocol of :mod:`agents.cli` (``add_arguments(parser)``,
``run(args) -> int``): ``analyze`` (:func:`envs.analysis.loop_analysis.analyze`), ``tune``
(:func:`baselines.rules.tune.tune`), ``reproduce`` (:func:`baselines.reproduction.reproduce.run_reproductions`),
``train`` (:mod:`agents.training`), ``evaluate`` (:mod:`agents.evaluation`), ``bench``
(:mod:`agents.bench`), ``sweep`` and ``regimes`` (:mod:`agents.sweeps`) and ``process``
(:mod:`envs.process` with :mod:`agents.evaluation`).  The libraries know nothing of the command line:
argparse is imported here and in :mod:`agents.cli` only.  :mod:`.arguments` holds what the
subcommands share.
"""
