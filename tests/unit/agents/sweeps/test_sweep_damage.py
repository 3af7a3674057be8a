"""``deadtime sweep`` with damaged files, interruptions and misspelled policies: one line, the exit
status, nothing final written, nothing lost.  No Ray cluster is started here (the checks come
before the connection, or Ray's side is stood in for); the end-to-end cases are in ``test_sweep.py``.
"""

from __future__ import annotations

import json
import shutil
import signal
from pathlib import Path

import pytest
from in_process import run_deadtime as run


REPO = Path(__file__).resolve().parents[4]
SMOKE = REPO / "configs" / "sweeps" / "smoke.yaml"
TRIAL = "sac-PID-v3-s0"


def _snapshot(directory: Path) -> dict[str, bytes]:
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


@pytest.fixture
def started(tmp_path: Path) -> Path:
    """A sweep directory of ``smoke.yaml`` as an interrupted sweep leaves it (no Ray needed to read it)."""
    out = tmp_path / "out"
    (out / "runs" / TRIAL).mkdir(parents=True)
    shutil.copy(SMOKE, out / "sweep.yaml")
    (out / "sessions.json").write_text("[]\n")
    (out / "runs" / TRIAL / "run.json").write_text('{"status": "interrupted"}\n')
    return out


DAMAGES = {
    "sessions-truncated": ("sessions.json", '[{"finished": "2026', "{out}/sessions.json is damaged: not valid JSON ("),
    "sessions-not-a-list": ("sessions.json", "{}", "{out}/sessions.json is damaged: a JSON array was expected, got dict"),
    "run-json-garbage": (f"runs/{TRIAL}/run.json", "\x00\x00", f"trial {TRIAL}: {{out}}/runs/{TRIAL}/run.json is damaged: "
                         "not valid JSON ("),
    "sessions-wall-time-nan": ("sessions.json", '[{"status": "finished", "wall_time_s": "NaN"}]',
                               "{out}/sessions.json is damaged: entry 1 is not a session with a wall_time_s >= 0 (got 'NaN')"),
    "checkpoint-index-garbage": (f"runs/{TRIAL}/checkpoints/latest.json", "garbage",
                                 f"trial {TRIAL}: {{out}}/runs/{TRIAL}/checkpoints/latest.json is damaged: not valid JSON ("),
}


@pytest.mark.parametrize(("name", "text", "message"), DAMAGES.values(), ids=DAMAGES.keys())
def test_a_damaged_record_is_named_before_the_resume_starts(started: Path, name: str, text: str, message: str) -> None:
    (started / name).parent.mkdir(parents=True, exist_ok=True)
    (started / name).write_text(text)
    before = _snapshot(started)
    status, out, err = run("sweep", "--config", str(SMOKE), "--out", str(started), "--resume")
    assert (status, out) == (2, "")
    assert err.count("\n") == 1 and err.startswith("deadtime sweep: error: " + message.format(out=started)), err
    assert _snapshot(started) == before


@pytest.mark.parametrize(
    ("policies", "message"),
    [("[all-rules, oracel]", "evaluation.policies: unknown policy 'oracel' (did you mean 'oracle'?)"),
     ("[all-rules]", "evaluation.policies must include 'oracle'"),
     ("[oracle, oracle-full]", "evaluation.policies must include at least one rule of DeadTime/PID-v3")],
    ids=["misspelled", "no-oracle", "no-rule"],
)
def test_evaluation_policies_are_checked_before_any_trial(tmp_path: Path, policies: str, message: str) -> None:
    path = tmp_path / "sweep.yaml"
    path.write_text(SMOKE.read_text().replace("policies: [all-rules, oracle]", f"policies: {policies}").replace(
        "config: configs/sac.yaml", f"config: {REPO / 'configs' / 'sac.yaml'}"))
    status, out, err = run("sweep", "--config", str(path), "--out", str(tmp_path / "out"))
    assert (status, out) == (2, "")
    assert err.count("\n") == 1 and message in err and str(path) in err, err
    assert not (tmp_path / "out").exists()


def test_ctrl_c_exits_130_writes_nothing_final_and_says_how_to_resume(tmp_path: Path, monkeypatch) -> None:
    import agents.sweeps.run as sweep_run

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt  # as _train_all raises once Ctrl-C has stopped the Tune experiment

    import ray

    monkeypatch.setattr(sweep_run, "connect", lambda ray, address: None)
    monkeypatch.setattr(ray, "cluster_resources", lambda: {"CPU": 2.0})
    monkeypatch.setattr(sweep_run, "_train_all", interrupted)
    out = tmp_path / "out dir"
    status, printed, err = run("sweep", "--config", str(SMOKE), "--out", str(out))
    assert (status, printed) == (130, "")
    assert err == ("deadtime sweep: interrupted; no summary written, the trials' checkpoints and the evaluations' caches "
                   f"are kept; continue with: deadtime sweep --config {SMOKE} --out '{out}' --resume\n")
    assert sorted(p.name for p in out.iterdir()) == ["sessions.json", "sweep.yaml"]  # what --resume needs, nothing final
    (session,) = json.loads((out / "sessions.json").read_text())
    assert session["status"] == "interrupted"  # its time counts in the summary of the resumed sweep


def test_tune_stop_passes_the_first_sigint_to_tune_and_raises_on_the_second() -> None:
    from agents.sweeps.interrupts import TuneStop

    received = []
    inherited = signal.getsignal(signal.SIGINT)  # the default handler, or SIG_IGN in a job started in the background
    previous = signal.signal(signal.SIGUSR1, lambda signum, frame: received.append(signum))  # Tune's graceful stop
    try:
        with TuneStop() as stop:
            signal.raise_signal(signal.SIGINT)
            assert stop.requested and received == [signal.SIGUSR1]
            with pytest.raises(KeyboardInterrupt):
                signal.raise_signal(signal.SIGINT)
        signal.signal(signal.SIGUSR1, signal.SIG_DFL)
        with TuneStop() as stop, pytest.raises(KeyboardInterrupt):  # Tune not listening yet: stop at once
            signal.raise_signal(signal.SIGINT)
    finally:
        signal.signal(signal.SIGUSR1, previous)
    assert signal.getsignal(signal.SIGINT) is inherited  # restored, whatever it was


def test_a_truncated_experiment_state_is_said_and_the_trials_run_as_a_new_experiment(tmp_path: Path, capsys) -> None:
    """Tune would fail to restore it, start an experiment without the trials' configs, and every
    trial would fail with ``KeyError: 'trial'``."""
    from agents.sweeps.run import _restored

    experiment = tmp_path / "tune" / "trials"
    experiment.mkdir(parents=True)
    (experiment / "tuner.pkl").write_bytes(b"")
    state = experiment / "experiment_state-2026-01-01_00-00-00.json"
    state.write_text('{"trial_data": [["{\\n  \\"stub\\": fal')
    assert _restored(tmp_path / "tune") is None
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"deadtime sweep: cannot restore {experiment}: {state} is damaged: not valid JSON ("), err
    assert err.rstrip().endswith("running its trials again as a new Tune experiment, each resuming its run directory")


def test_a_nan_cost_fails_the_summary_naming_the_file_and_leaves_the_old_summary(tmp_path: Path) -> None:
    from agents.sweeps.config import evaluation_directory, load_sweep
    from agents.sweeps.summary import write_summary

    sweep = load_sweep(SMOKE)
    out = tmp_path / "out"
    baselines = evaluation_directory(out, "DeadTime/PID-v3", "baselines")
    baselines.mkdir(parents=True)
    (baselines / "per_plant.csv").write_text("index,subset,plant,seed,policy,cost\n0,test,test-0,0,oracle,nan\n")
    for name in ("summary.json", "summary.md", "summary.csv"):
        (out / name).write_text("earlier")
    with pytest.raises(ValueError, match=r"per_plant.csv, line 2: not a finite cost >= 0 of a plant \('nan'\)"):
        write_summary(sweep, sweep.trials(), out, {})
    assert {p.name: p.read_text() for p in out.glob("summary.*")} == dict.fromkeys(
        ("summary.json", "summary.md", "summary.csv"), "earlier")


def test_files_written_together_are_all_or_none(tmp_path: Path) -> None:
    from agents.files.writer import atomic_write_all

    for name in ("a", "b"):
        (tmp_path / name).write_text("old")

    def broken(handle) -> None:
        raise OSError("disk full")

    with pytest.raises(ValueError, match=r"b could not be written \(disk full\)"):
        atomic_write_all({tmp_path / "a": lambda handle: handle.write(b"new"), tmp_path / "b": broken})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b"]  # no temporary left
    assert (tmp_path / "a").read_text() == (tmp_path / "b").read_text() == "old"
    atomic_write_all({tmp_path / "a": lambda handle: handle.write(b"new"), tmp_path / "b": lambda handle: handle.write(b"new")})
    assert (tmp_path / "a").read_text() == (tmp_path / "b").read_text() == "new"


def test_a_checkpoint_fallback_of_a_trial_is_said_on_the_terminal(started: Path) -> None:
    """The line ``deadtime train`` prints in the trial's Ray worker, where the user never sees it, is
    said by the driver before the sweep resumes."""
    from agents.sweeps.config import load_sweep
    from agents.sweeps.resume import check_resumable

    run_dir = started / "runs" / TRIAL
    _checkpoint(run_dir, 100)
    directory = _checkpoint(run_dir, 200)
    (directory / "state_200.pkl").write_bytes(b"truncated")
    notes = check_resumable(load_sweep(SMOKE), started)
    assert len(notes) == 1
    assert notes[0].startswith(f"trial {TRIAL}: {directory / 'state_200.pkl'} is damaged: 9 bytes, ")
    assert notes[0].endswith("resuming from checkpoint_100.json (100 steps) instead")


def _checkpoint(run_dir: Path, steps: int) -> Path:
    """A checkpoint of ``steps`` steps as ``save_checkpoint`` writes its manifests (stand-in file contents)."""
    from agents.files.writer import atomic_write, file_digest, write_json

    directory = run_dir / "checkpoints"
    manifest = {"format": 2, "num_timesteps": steps, "periodic_checkpoint": steps, "files": {}, "evaluations": []}
    for role, suffix in (("model", "zip"), ("state", "pkl")):
        path = atomic_write(directory / f"{role}_{steps}.{suffix}", lambda handle: handle.write(bytes(range(256))))
        manifest[role] = path.name
        manifest["files"][path.name] = {"bytes": path.stat().st_size, "sha256": file_digest(path)}
    write_json(directory / f"checkpoint_{steps}.json", manifest)
    write_json(directory / "latest.json", manifest)
    return directory
