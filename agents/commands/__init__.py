"""The ``deadtime`` subcommands that front a function of ``envs`` or ``baselines``.

``analyze`` (:func:`envs.analysis.loop_analysis.analyze`), ``tune`` (:func:`baselines.rules.tune.tune`)
and ``reproduce`` (:func:`baselines.reproduction.reproduce.run_reproductions`): their command-line
layer lives here, in ``agents``, because ``envs`` and ``baselines`` know nothing of the command line.
Each module follows the protocol of :mod:`agents.cli` (``add_arguments(parser)``, ``run(args) -> int``);
:mod:`.arguments` holds what they and ``deadtime evaluate`` share.
"""
