"""What ``deadtime sweep --resume`` checks before it connects to Ray, reading only.

A resumed sweep rewrites ``DIR/sessions.json`` (:mod:`agents.sweeps.sessions`) and each trial's ``run.json``,
and each trial resumes its run directory from its newest intact checkpoint.  A damaged record, or a
run with no intact checkpoint, is named here in one line (:class:`agents.files.reader.DamagedFileError`)
before any trial starts; a trial that falls back on an older checkpoint is said here, on the user's
terminal, not only in a Ray worker's log.  :func:`experiment_state_problem` says why Tune's
experiment state of an earlier session cannot be restored (then the trials run as a new Tune
experiment, each resuming its run directory, which is as exact).
"""

from __future__ import annotations

from pathlib import Path

from agents.sweeps.config import SweepConfig
from agents.sweeps.sessions import read_sessions
from agents.files.reader import DamagedFileError, FileProblem, damaged, read_json, read_record

__all__ = ["check_resumable", "experiment_state_problem"]


def check_resumable(sweep: SweepConfig, out: Path) -> list[str]:
    """Check the records and run directories of the sweep in ``out``; the lines to print about them.

    Raises
    ------
    DamagedFileError
        Naming ``sessions.json``, a trial's ``run.json`` or checkpoint that is damaged (with no
        intact checkpoint to fall back on), and the trial.
    """
    from agents.training.checkpoints import find_checkpoint

    read_sessions(out / "sessions.json")
    notes = []
    for trial in sweep.trials():
        run_dir = out / "runs" / trial.name
        try:
            read_record(run_dir / "run.json", dict)
            _, note = find_checkpoint(run_dir)
        except DamagedFileError as error:
            raise DamagedFileError(f"trial {trial.name}: {error}") from None
        if note:
            notes.append(f"trial {trial.name}: {note}")
    return notes


def experiment_state_problem(experiment: Path) -> str | None:
    """None if the newest ``experiment_state-*.json`` of a Tune experiment directory reads as JSON,
    else what is wrong with it, naming it."""
    states = sorted(experiment.glob("experiment_state-*.json"))
    if not states:
        return f"{experiment} holds no experiment_state-*.json"
    try:
        read_json(states[-1])
    except FileProblem as error:
        return str(damaged(error, states[-1]))
    return None
