"""``deadtime train``: train a stable-baselines3 agent, or fit the learned rule, from a YAML config.

::

    deadtime train --config configs/ppo.yaml [--env ID] [--out DIR] [--seed N] [--resume] [key=value ...]

The config is resolved (:func:`agents.training.config.load_config`), and here, once, its ``algorithm``
chooses the fit: a stable-baselines3 agent (:func:`agents.training.train.train`), for
``algorithm: learned-rule`` the learned rule (:func:`agents.training.learned_rule.fit`), for
``algorithm: selector`` a selector (:func:`agents.training.selector.fit`).  What a run
writes, how it resumes and what its seed drives: :mod:`agents.training.train` and
:mod:`agents.training.learned_rule`.

Ctrl-C prints the command that continues the run and exits with status 130, SIGTERM the same with
status 143; SIGINT or SIGTERM during an agent's training stops it at the next rollout boundary with a
checkpoint, and exits with 128 + the signal.
"""

from __future__ import annotations

import argparse
import dataclasses
import shlex
import signal
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from agents.interruptions import interrupted, terminated
from agents.limits import MAX_BUFFER_SIZE, MAX_ENVS, MAX_EVAL_EPISODES, MAX_LAYER_WIDTH, MAX_LAYERS, MAX_NESTING, MAX_YAML_NODES

if TYPE_CHECKING:
    from agents.training.config import TrainConfig
    from agents.training.learned_rule_config import LearnedRuleConfig
    from agents.training.selector_config import SelectorConfig

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime train``."""
    parser.add_argument("--config", help="a YAML config (configs/<algorithm>.yaml, or a run's config.yaml); "
                        f"optional with --resume --out DIR.  Limits (agents/limits.py): n_envs <= {MAX_ENVS}, "
                        f"n_eval_episodes <= {MAX_EVAL_EPISODES}, hyperparameters.buffer_size, batch_size and n_steps * n_envs "
                        f"<= {MAX_BUFFER_SIZE}, "
                        f"policy_kwargs.net_arch at most {MAX_LAYERS} layers of {MAX_LAYER_WIDTH} units, "
                        f"nesting <= {MAX_NESTING} levels, <= {MAX_YAML_NODES} values with aliases expanded")
    parser.add_argument("--env", help="environment id (selects the config's entry; default the config's env_id)")
    parser.add_argument("--out", help="run directory (default: the config's output_dir, else runs/<algo>-<env>-s<seed>)")
    parser.add_argument("--seed", type=int, help="the training seed, an integer >= 0 (the same as the override seed=N; "
                        "default the config's)")
    parser.add_argument("--resume", action="store_true", help="continue the run in the run directory from its latest checkpoint")
    parser.add_argument("overrides", nargs="*", metavar="key=value",
                        help="config overrides, dotted keys for nesting (e.g. hyperparameters.n_steps=32 seed=3)")


def run(args: argparse.Namespace) -> int:
    """``deadtime train``: resolve the config, train or fit, report where the agent is."""
    from agents.training.config import load_config
    from agents.training.learned_rule_config import LearnedRuleConfig
    from agents.training.selector_config import SelectorConfig
    from agents.training.train import with_seed

    if args.config is None:
        if not (args.resume and args.out):
            raise ValueError("--config is required (it may be left out only with --resume --out DIR)")
        config_path = Path(args.out) / "config.yaml"
        if not config_path.is_file():
            raise ValueError(f"{args.out} holds no config.yaml to resume from")
    else:
        config_path = Path(args.config)
        if not config_path.is_file():
            raise ValueError(f"--config {args.config}: no such file")
    config = load_config(config_path, env_id=args.env, overrides=with_seed(args.overrides, args.seed))
    if args.out is not None:
        config = dataclasses.replace(config, output_dir=args.out)
    command = shlex.join(_command_from(args))
    if isinstance(config, LearnedRuleConfig):
        return _fit_learned_rule(config, resume=args.resume, command=command)
    if isinstance(config, SelectorConfig):
        return _fit_selector(config, resume=args.resume, command=command)
    return _train_agent(config, resume=args.resume, command=command)


def _command_from(args: argparse.Namespace) -> list[str]:
    words = ["deadtime", "train"]
    for option in ("config", "env", "out", "seed"):
        if getattr(args, option) is not None:
            words += [f"--{option}", str(getattr(args, option))]
    return words + (["--resume"] if args.resume else []) + list(args.overrides)


def _interrupted(error: BaseException, run_dir: Path, kept: str) -> int:
    """After Ctrl-C or SIGTERM (``error``, maybe wrapped by a compiled call) ends ``deadtime train`` outside
    a training step: one line saying what is ``kept`` and how to go on; status 130, or 143 for SIGTERM.

    ``--resume --out DIR`` is advised only where it works, a run directory with its ``config.yaml``;
    before that is written nothing of the run exists, and the same command starts it again.
    """
    how = "terminated" if terminated(error) else "interrupted"
    if not (run_dir / "config.yaml").is_file():
        line = f"deadtime train: {how} before the run started; nothing was written (run the same command again)"
    else:
        line = f"deadtime train: {how}; {kept}; continue with: deadtime train --out {shlex.quote(str(run_dir))} --resume"
    print(f"\n{line}", file=sys.stderr)
    return 143 if terminated(error) else 130


def _train_agent(config: TrainConfig, *, resume: bool, command: str) -> int:
    """Train a stable-baselines3 agent; a stop by signal or Ctrl-C says how to continue."""
    from agents.training.train import checkpoint_steps, run_directory, train

    try:
        result = train(config, resume=resume, command=command)
    except KeyboardInterrupt as error:
        run_dir = run_directory(config)
        return _interrupted(error, run_dir, f"latest checkpoint at {checkpoint_steps(run_dir)} steps")
    if result.status == "interrupted":
        name = signal.Signals(result.stopped_by).name if result.stopped_by else "a stop request"
        print(f"deadtime train: stopped by {name}; checkpoint of {result.num_timesteps} steps in "
              f"{result.run_dir / 'checkpoints'}; continue exactly with: "
              f"deadtime train --out {shlex.quote(str(result.run_dir))} --resume", file=sys.stderr)
        return 128 + (result.stopped_by or 2)
    print(f"{result.num_timesteps} steps; this session trained {result.session_steps} in {result.train_seconds:.1f} s"
          f"{f' ({result.steps_per_second:.1f} steps/s)' if result.session_steps > 0 else ''}; best validation cost {result.best_cost:.6g}")
    print(f"agent: {result.run_dir / 'model.zip'} (best: {result.run_dir / 'best_model.zip'})")
    return 0


def _fit_learned_rule(config: LearnedRuleConfig, *, resume: bool, command: str) -> int:
    """Fit the learned rule, report where the rule is (exit 130 on Ctrl-C, 143 on SIGTERM, with the command
    that continues)."""
    from agents.files.reader import read_json
    from agents.training.learned_rule import certification_line, fit, labels_kept, run_directory

    try:
        result = fit(config, resume=resume, command=command)
    except (KeyboardInterrupt, SystemError) as error:
        if not interrupted(error):
            raise  # a SystemError that is not Ctrl-C or SIGTERM inside a compiled call
        run_dir = run_directory(config)
        kept = f"{labels_kept(config, run_dir)} labelled training plants are kept in {run_dir / 'dataset'}"
        return _interrupted(error, run_dir, kept)
    rule = read_json(result.run_dir / "learned_rule.json", dict)
    print(f"{result.num_timesteps} training plants ({result.session_steps} labelled by the oracle in this session, "
          f"{result.train_seconds:.1f} s); chosen {rule['kind']} with margin {rule['margin']:g}"
          f"{' (scaled by the spread)' if rule.get('margin_scale') == 'spread' else ''}: "
          f"validation mean cost {result.best_cost:.6g}")
    if rule.get("certification"):
        print(certification_line(rule["certification"]))
    print(f"learned rule: {result.run_dir / 'learned_rule.json'} (deadtime evaluate --policies learned={result.run_dir})")
    return 0


def _fit_selector(config: SelectorConfig, *, resume: bool, command: str) -> int:
    """Fit a selector, report where it is (exit 130 on Ctrl-C, 143 on SIGTERM: a selector's fit starts
    again, its own learned design's labels are kept)."""
    from agents.training.selector import fit, run_directory

    try:
        result = fit(config, resume=resume, command=command)
    except (KeyboardInterrupt, SystemError) as error:
        if not interrupted(error):
            raise
        return _interrupted(error, run_directory(config), "a finished fit of its learned candidate is kept")
    print(f"selector: {result.run_dir / 'selector.json'} (deadtime evaluate --policies selector={result.run_dir})")
    return 0
