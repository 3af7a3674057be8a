"""The Ray Tune side of ``deadtime sweep`` (:mod:`agents.commands.sweep`): trials, evaluations, progress.

Imported only when a sweep runs (Ray is an optional extra, ``pip install -e '.[sweep]'``).
"""

from __future__ import annotations

import logging
import os
import pickle
import signal
import sys
import time
from pathlib import Path
from typing import Any

from ray import tune

from agents.files.lock import LOCK_NAME, folder_lock
from agents.files.reader import read_text
from agents.files.writer import write_text
from agents.sweeps.cluster import connect
from agents.sweeps.config import SweepConfig, Trial, evaluation_directory
from agents.sweeps.interrupts import TuneStop
from agents.sweeps.resume import check_resumable, experiment_state_problem
from agents.sweeps.sessions import SessionRecord

__all__ = ["Progress", "run_sweep", "trial_function"]


# ------------------------------------------------------------------------------- the sweep
def _check_directory(sweep_file: Path, out: Path, resume: bool) -> None:
    """Check that ``out`` fits the request, writing nothing (a refused sweep leaves no trace)."""
    saved = out / "sweep.yaml"
    if saved.is_file():
        if not resume:
            raise ValueError(f"{out} already holds a sweep; pass --resume to finish it, or choose another --out")
        if read_text(saved) != read_text(sweep_file):
            raise ValueError(f"--resume: {sweep_file} differs from the sweep in {saved}; resume with the same file")
    elif out.exists() and any(path.name != LOCK_NAME for path in out.iterdir()):
        raise ValueError(f"{out} is not empty and holds no sweep.yaml; choose another --out")


def run_sweep(sweep: SweepConfig, sweep_file: Path, out: Path, *, address: str | None = None, resume: bool = False) -> dict[str, Any]:
    """Train every trial on Ray Tune, evaluate, and write the summary; returns ``summary.json``'s object.

    The session is recorded in ``DIR/sessions.json`` while it runs, an interrupted one too
    (:mod:`agents.sweeps.sessions`).
    """
    started = time.perf_counter()
    out = out.resolve()
    with folder_lock(out, "sweep"):  # before the folder is checked: a second sweep on it is refused
        return _session(sweep, sweep_file, out, address, resume, started)


def _session(sweep: SweepConfig, sweep_file: Path, out: Path, address: str | None, resume: bool, started: float) -> dict[str, Any]:
    """:func:`run_sweep` in ``out``, whose lock is held."""
    import ray

    _check_directory(sweep_file, out, resume)
    if resume:
        for note in check_resumable(sweep, out):
            print(f"deadtime sweep: {note}", file=sys.stderr, flush=True)
    connect(ray, address)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "sweep.yaml", read_text(sweep_file))
    with SessionRecord(out, resume, ray.cluster_resources().get("CPU"), started=started) as session:
        results = _train_all(sweep, out, resume)
        failed = {name: error for name, error in results.items() if error is not None}
        for name, error in failed.items():
            print(f"trial {name} failed: {error}", file=sys.stderr)
        trials = [trial for trial in sweep.trials() if trial.name not in failed]
        _evaluate_all(ray, sweep, trials, out)
        from agents.sweeps.summary import write_summary

        summary = write_summary(sweep, trials, out, failed, session.finished())
        session.save()
    return summary


# ------------------------------------------------------------------------------- the trials
def trial_function(config: dict[str, Any]) -> None:
    """One Tune trial: ``deadtime train`` of ``config["trial"]`` into ``config["out"]/runs/NAME`` (an agent
    trained, or a learned rule fitted)."""
    from agents.training.learned_rule_config import LearnedRuleConfig
    from agents.training.selector_config import SelectorConfig

    trial = Trial.from_dict(config["trial"])
    run_dir = Path(config["out"]) / "runs" / trial.name
    train_config = trial.train_config(run_dir)
    command = f"deadtime sweep (trial {trial.name})"
    if isinstance(train_config, LearnedRuleConfig | SelectorConfig):  # a fit that reports when it ends only
        from agents.training.learned_rule import fit as fit_learned_rule
        from agents.training.selector import fit as fit_selector

        fit = fit_learned_rule if isinstance(train_config, LearnedRuleConfig) else fit_selector
        result = fit(train_config, resume=True, command=command)
    else:
        from agents.sweeps.reporter import TuneReporter
        from agents.training.train import train

        result = train(train_config, resume=True, command=command, callbacks=[TuneReporter(train_config.total_timesteps)])
    tune.report({"timesteps": result.num_timesteps, "best_cost": result.best_cost, "final_cost": result.final_cost,
                 "finished": result.status == "finished"})


class Progress(tune.Callback):
    """Tune callback: one line per finished or failed trial, and a bar over the trials.

    The bar is left out of the pickled state, so that the callback pickles with Tune's experiment
    state (and is made again when a restored sweep runs).
    """

    def __init__(self, total: int) -> None:
        self.total, self.bar = total, None

    def setup(self, **info: Any) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=self.total, desc="trials", unit="trial", file=sys.stderr)

    def __getstate__(self) -> dict[str, Any]:
        return {"total": self.total, "bar": None}

    def _write(self, line: str) -> None:
        if self.bar is None:
            self.setup()
        self.bar.write(line, file=sys.stderr)
        self.bar.update()

    def on_trial_complete(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
        result, name = trial.last_result or {}, trial.config["trial"]
        self._write(f"finished {name['label']} {name['env_id']} seed {name['seed']}: {result.get('timesteps')} "
                    f"steps, best validation cost {result.get('best_cost', float('nan')):.6g}")

    def on_experiment_end(self, trials: list, **info: Any) -> None:
        """Close the bar, so that the lines printed after the experiment come after it."""
        if self.bar is not None:
            self.bar.close()

    def on_trial_error(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
        name = trial.config["trial"]
        self._write(f"failed {name['label']} {name['env_id']} seed {name['seed']} (after its retries)")


def _train_all(sweep: SweepConfig, out: Path, resume: bool) -> dict[str, str | None]:
    """Run (or restore and finish) the Tune experiment; each trial's name with its error or None.

    Raises
    ------
    KeyboardInterrupt
        After Ctrl-C has stopped the experiment (:class:`agents.sweeps.interrupts.TuneStop`).
    """
    trials = sweep.trials()
    storage = out / "tune"
    tuner = _restored(storage) if resume else None
    if tuner is None:
        run_config = tune.RunConfig(
            name=_free_name(storage), storage_path=str(storage), verbose=0,
            failure_config=tune.FailureConfig(max_failures=sweep.failure.max_failures),
            callbacks=[Progress(len(trials))],
        )  # fmt: skip
        space = {"trial": tune.grid_search([t.to_dict() for t in trials]), "out": str(out)}
        tuner = tune.Tuner(_trainable(), param_space=space, run_config=run_config)
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")  # Tune's classic reporter, which verbose=0 silences
    with TuneStop() as stop:
        grid = tuner.fit()
    if stop.requested:
        from agents.interruptions import Terminated

        raise Terminated if stop.signum == signal.SIGTERM else KeyboardInterrupt
    outcome: dict[str, str | None] = {}
    for result in grid:
        trial = result.config["trial"]
        name = Trial.from_dict(trial).name
        finished = result.error is None and (result.metrics or {}).get("finished")
        outcome[name] = None if finished else _error_line(result.error)
    missing = [t.name for t in trials if t.name not in outcome]
    outcome.update({name: "never ran" for name in missing})
    return outcome


def _trainable() -> Any:
    return tune.with_resources(trial_function, {"cpu": 1})


def _latest_experiment(storage: Path) -> Path | None:
    names = sorted((p for p in storage.glob("trials*") if p.is_dir()), key=lambda p: p.stat().st_mtime)
    return names[-1] if names else None


def _free_name(storage: Path) -> str:
    """``trials``, or ``trials-2``, ``trials-3`` ... where an earlier experiment could not be restored."""
    name, index = "trials", 1
    while (storage / name).exists():
        index += 1
        name = f"trials-{index}"
    return name


def _restored(storage: Path) -> Any:
    """The latest Tune experiment in ``storage`` restored (``Tuner.restore``), or None.

    An experiment state that this version cannot read (written before a module it names moved)
    is reported in one line and left in place; a new experiment then runs the same trials, and each
    trial resumes its own run directory from its checkpoint, so nothing trained is lost.
    """
    path = _latest_experiment(storage)
    if path is None or not tune.Tuner.can_restore(str(path)):
        return None
    problem = experiment_state_problem(path)
    if problem is not None:
        print(f"deadtime sweep: cannot restore {path}: {problem}; running its trials again as a new Tune "
              "experiment, each resuming its run directory", file=sys.stderr)
        return None
    # Tune warns about every trial without metrics: those not started before the interruption, not failures
    logging.getLogger("ray.tune.analysis.experiment_analysis").setLevel(logging.ERROR)
    try:
        return tune.Tuner.restore(str(path), trainable=_trainable(), resume_unfinished=True, restart_errored=True)
    except (ImportError, AttributeError, pickle.UnpicklingError) as error:
        print(f"deadtime sweep: cannot restore {path} ({type(error).__name__}: {error}); running its trials again "
              "as a new Tune experiment, each resuming its run directory", file=sys.stderr)
        return None


def _error_line(error: BaseException | None) -> str:
    if error is None:
        return "did not finish"
    cause = getattr(error, "cause", None) or error
    text = str(cause).strip().splitlines()
    return f"{type(cause).__name__}: {text[-1] if text else ''}"


# ---------------------------------------------------------------------------- evaluation
def _evaluate_task(env_id: str, policies: str, n: int, seed: int, resamples: int, directory: str,
                   env_kwargs: dict) -> list[str]:
    """One evaluation; the lines it would print on stderr (a Ray task's stderr stays in its log)."""
    from agents.evaluation.evaluate import evaluate

    lines: list[str] = []
    evaluate(env_id, policies, n, seed, Path(directory), resamples=resamples, plots=False, env_kwargs=env_kwargs,
             warn=lines.append)
    return lines


def _evaluate_all(ray: Any, sweep: SweepConfig, trials: list[Trial], out: Path) -> None:
    """The baselines once per environment and every trained agent, as Ray tasks (one CPU each)."""
    from tqdm import tqdm

    task = ray.remote(num_cpus=1)(_evaluate_task)
    evaluation = sweep.evaluation
    jobs = [(env, ",".join(evaluation.policies), evaluation_directory(out, env, "baselines")) for env in sweep.envs()]
    jobs += [(t.env_id, f"agent={out / 'runs' / t.name}", evaluation_directory(out, t.env_id, t.name)) for t in trials]
    regime = dict(sweep.env_kwargs)
    pending = [task.remote(env, policies, evaluation.n, evaluation.seed, evaluation.resamples, str(directory), regime)
               for env, policies, directory in jobs]
    directories = {ref: directory for ref, (_, _, directory) in zip(pending, jobs)}
    with tqdm(total=len(pending), desc="evaluations", unit="run", file=sys.stderr) as bar:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            try:
                lines = ray.get(done[0])
            except ray.exceptions.RayTaskError as error:
                raise ValueError(f"the evaluation into {directories[done[0]]} failed ({_error_line(error)})") from None
            for line in lines:
                bar.write(f"deadtime sweep: {line}", file=sys.stderr)
            bar.update(len(done))
