"""What every subcommand of ``deadtime`` shares (agents.cli): a description in ``--help``, a quiet end
when the reader of the standard output has gone, and misspelled names answered with the closest one;
and ``deadtime train --seed``."""

from __future__ import annotations

import subprocess
import sys

import pytest

from agents.cli import BROKEN_PIPE, COMMANDS, main
from agents.runtime import REPO
from agents.training.config import load_config
from agents.training.train import with_seed

SAC = str(REPO / "configs" / "sac.yaml")


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_subcommand_has_a_one_sentence_description(name, capsys):
    with pytest.raises(SystemExit) as done:
        main([name, "--help"])
    assert done.value.code == 0
    description = COMMANDS[name].description
    assert description[0].isupper() and description.endswith(".") and description in " ".join(capsys.readouterr().out.split())


def test_a_reader_gone_ends_the_command_quietly():
    """``deadtime tune --list | head -2``: status 141, nothing on stderr (no "Broken pipe")."""
    process = subprocess.Popen([sys.executable, "-m", "agents.cli", "tune", "--list"], cwd=REPO,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
    process.stdout.close()  # before the command writes: every write fails
    error = process.stderr.read()
    assert process.wait(timeout=120) == BROKEN_PIPE == 141
    assert error == b""


def _one_line(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1
    return captured.err


@pytest.mark.parametrize("env_id", ["DeadTime/PID-v9", "DeadTim/PID-v3", "deadtime/pid-v3"])
def test_a_misspelled_environment_names_the_closest(capsys, tmp_path, monkeypatch, env_id):
    monkeypatch.chdir(tmp_path)
    closest = "(did you mean 'DeadTime/PID-v3'?)"
    assert closest in _one_line(capsys, ["evaluate", "--env", env_id, "--policies", "oracle", "--out", "out"])
    assert closest in _one_line(capsys, ["train", "--config", SAC, "--env", env_id, "--out", "run"])
    assert closest in _one_line(capsys, ["train", "--config", SAC, f"env_id={env_id}", "--out", "run"])
    assert list(tmp_path.iterdir()) == []


def test_a_module_prefixed_id_is_left_to_gymnasium_and_its_failure_is_one_line(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    line = _one_line(capsys, ["evaluate", "--env", "no_such_module:Foo-v0", "--policies", "oracle", "--out", "out"])
    assert line.startswith("deadtime evaluate: error: environment 'no_such_module:Foo-v0': No module named 'no_such_module'")
    assert "env_id 'no_such_module:Foo-v0'" in _one_line(capsys, ["train", "--config", SAC, "--env", "no_such_module:Foo-v0"])
    assert list(tmp_path.iterdir()) == []


def test_a_misspelled_rule_names_the_closest(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    plant = '{"num": [1], "den": [10, 1], "delay": 5}'
    assert "(did you mean 'simc-pi'?)" in _one_line(capsys, ["tune", "--rule", "simc-pii", "--plant", plant])
    assert "(did you mean 'simc-pi'?)" in _one_line(
        capsys, ["evaluate", "--env", "DeadTime/PID-v3", "--policies", "simc-pii,oracle", "--out", "out"])
    assert "(did you mean 'all-rules'?)" in _one_line(
        capsys, ["evaluate", "--env", "DeadTime/PID-v3", "--policies", "all-rule", "--out", "out"])
    assert list(tmp_path.iterdir()) == []


def test_train_seed_is_the_seed_override():
    assert with_seed(["total_timesteps=64"], None) == ["total_timesteps=64"]
    assert with_seed(["seed=5"], 5) == ["seed=5", "seed=5"]
    by_flag = load_config(SAC, overrides=with_seed([], 7))
    assert by_flag == load_config(SAC, overrides=["seed=7"]) and by_flag.seed == 7
    for conflicting in (["seed=4"], ["seed=true"], ["seed=3.0"]):
        with pytest.raises(ValueError, match=f"--seed 3 and the override '{conflicting[0]}' disagree"):
            with_seed(conflicting, 3)


def test_train_seed_conflicting_with_the_override_is_one_line_and_writes_nothing(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    line = _one_line(capsys, ["train", "--config", SAC, "--seed", "3", "seed=4", "--out", "run"])
    assert line == "deadtime train: error: --seed 3 and the override 'seed=4' disagree; give the seed once\n"
    assert "seed must be an integer >= 0, got -1" in _one_line(capsys, ["train", "--config", SAC, "--seed", "-1", "--out", "run"])
    assert list(tmp_path.iterdir()) == []
