"""Training the protocol's learners: each (regime, learner, seed) is a sweep trial, trained by ``deadtime train``.

A learner of a regime is the sweep trial ``Trial(label, env, seed, config, overrides, env_kwargs)``
(:class:`agents.sweeps.config.Trial`), trained by :func:`agents.training.train.train` (a learned rule
fitted by :func:`agents.training.learned_rule.fit`, a selector by :func:`agents.training.selector.fit`) with ``resume=True``: a finished fit is read back, an interrupted one continues from its checkpoint.  The
run directory is named by what determines the fit (environment, regime, config file and overrides),
so two regimes that declare the same learner in the same environment and regime share its fits, and
so do two protocols run with one ``--fits`` folder (a fit depends on no protocol stream: its training
plants and episodes are its config's, its seeds the protocol's).
"""

from __future__ import annotations

import hashlib
import json
import signal
from pathlib import Path

from agents.protocol.config import Learner, Regime, trial

__all__ = ["run_directory", "train_learner", "trial"]


def run_directory(fits: Path, regime: Regime, learner: Learner, seed: int) -> Path:
    """``FITS/LABEL-ENV-HASH/sSEED``: HASH of the environment, regime, config file and overrides."""
    identity = json.dumps([regime.env, dict(regime.env_kwargs), learner.label, Path(learner.config).read_text(),
                           list(learner.overrides)], sort_keys=True)
    digest = hashlib.sha256(identity.encode()).hexdigest()[:10]
    return fits / f"{learner.label}-{regime.env.split('/')[-1]}-{digest}" / f"s{seed}"


def train_learner(fits: Path, regime: Regime, learner: Learner, seed: int) -> Path:
    """Train (or resume, or read back) one seed of ``learner`` in ``regime``; returns its run directory.

    Raises
    ------
    ValueError
        If the fit was interrupted (it resumes when called again) or its config changed since it started.
    KeyboardInterrupt
        After SIGINT, or :class:`agents.interruptions.Terminated` after SIGTERM, during the fit (its
        checkpoint or labels kept).
    """
    from agents.training.learned_rule_config import LearnedRuleConfig
    from agents.training.selector_config import SelectorConfig

    directory = run_directory(fits, regime, learner, seed)
    config = trial(regime, learner, seed).train_config(directory)
    command = f"deadtime protocol run ({regime.name}, {learner.label}, seed {seed})"
    if isinstance(config, LearnedRuleConfig):
        from agents.training.learned_rule import fit

        result = fit(config, resume=True, command=command)
    elif isinstance(config, SelectorConfig):
        from agents.training.selector import fit as fit_selector

        result = fit_selector(config, resume=True, command=command)
    else:
        from agents.training.train import train

        result = train(config, resume=True, command=command)
    if result.status != "finished" and getattr(result, "stopped_by", None):  # SIGINT or SIGTERM: a checkpoint written
        from agents.interruptions import Terminated

        raise Terminated if result.stopped_by == signal.SIGTERM else KeyboardInterrupt
    if result.status != "finished":
        raise ValueError(f"the fit of {learner.label} seed {seed} in {regime.name} was interrupted; run again to resume")
    return directory
