"""How ``deadtime train`` ends when Ctrl-C or SIGTERM stops a fit outside a training step (the learned
rule's labelling, a selector's fit, an agent's second signal): status 130 or 143, as every command
(agents/interruptions.py), with one line saying what is kept and the command that continues; the run
itself is stubbed (the real signal on a real fit: test_learned_rule_fit.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.cli import main
from agents.interruptions import Terminated

ROOT = Path(__file__).resolve().parents[4]
FITS = {  # the config of each kind of run, and where its fit is looked up
    "learned-rule": ("learned_rule.yaml", "agents.training.learned_rule.fit"),
    "selector": ("selector.yaml", "agents.training.selector.fit"),
    "agent": ("ppo.yaml", "agents.training.train.train"),
}


def _stopped_by(error: BaseException, started: bool):
    """A fit that writes the run's config.yaml (if ``started``), then raises ``error``."""
    def fit(config, **_):
        if started:
            Path(config.output_dir).mkdir(parents=True)
            (Path(config.output_dir) / "config.yaml").write_text("{}\n")
        raise error
    return fit


def _wrapped(error: BaseException) -> SystemError:
    """``error`` raised inside a compiled (numba) call: a SystemError on its way out."""
    try:
        try:
            raise error
        except BaseException:  # noqa: BLE001
            raise SystemError("<built-in function> returned a result with an exception set")
    except SystemError as wrapped:
        return wrapped


STOPS = {"Ctrl-C": (KeyboardInterrupt(), 130, "interrupted"), "SIGTERM": (Terminated(), 143, "terminated"),
         "Ctrl-C-in-numba": (_wrapped(KeyboardInterrupt()), 130, "interrupted"),
         "SIGTERM-in-numba": (_wrapped(Terminated()), 143, "terminated")}
"""How a stop reaches the command (an agent's training is never stopped inside a compiled call)."""


@pytest.mark.parametrize("kind, error, status, word", [
    pytest.param(kind, *stop, id=f"{kind}-{name}") for kind in FITS for name, stop in STOPS.items()
    if kind != "agent" or "numba" not in name])
def test_a_stopped_fit_exits_130_or_143_with_the_command_that_continues(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                       capsys: pytest.CaptureFixture[str], kind: str,
                                                                       error: BaseException, status: int, word: str) -> None:
    config, target = FITS[kind]
    monkeypatch.setattr(target, _stopped_by(error, started=True))
    run_dir = tmp_path / "run"
    assert main(["train", "--config", str(ROOT / "configs" / config), "--out", str(run_dir)]) == status
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[-1].startswith(f"deadtime train: {word}; ") and "Traceback" not in "".join(lines), lines
    assert lines[-1].endswith(f"; continue with: deadtime train --out {run_dir} --resume"), lines


@pytest.mark.parametrize("error, status, word", [(KeyboardInterrupt(), 130, "interrupted"), (Terminated(), 143, "terminated")],
                         ids=["Ctrl-C", "SIGTERM"])
def test_a_fit_stopped_before_its_run_started_says_to_run_the_command_again(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], error: BaseException, status: int,
        word: str) -> None:
    monkeypatch.setattr(FITS["learned-rule"][1], _stopped_by(error, started=False))
    assert main(["train", "--config", str(ROOT / "configs" / "learned_rule.yaml"), "--out", str(tmp_path / "run")]) == status
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        f"deadtime train: {word} before the run started; nothing was written (run the same command again)")


def test_a_system_error_that_is_no_interruption_is_not_taken_for_one(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(FITS["learned-rule"][1], _stopped_by(SystemError("a bug"), started=True))
    with pytest.raises(SystemError, match="a bug"):
        main(["train", "--config", str(ROOT / "configs" / "learned_rule.yaml"), "--out", str(tmp_path / "run")])
