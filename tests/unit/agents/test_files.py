"""The files of ``deadtime`` (:mod:`agents.files`): what is read is read within bounds and any problem
is one line naming the file; what is written is written whole or not at all; an output folder is
held by one run at a time; damaged state is named, never trusted nor silently restarted."""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from in_process import run_deadtime as run

from agents.files.lock import LOCK_NAME, FolderInUse, folder_lock
from agents.files.reader import FileProblem, load_yaml, load_yaml_file, parse_json, read_csv, read_json, read_text
from agents.files.writer import atomic_write_all, write_text

REPO = Path(__file__).resolve().parents[3]


# ------------------------------------------------------------------------------------- reading
@pytest.mark.parametrize(("text", "value"), [("1e-3", 1e-3), ("3E4", 3e4), ("-2.5e+2", -250.0), ("1.0e5", 1e5), ("7", 7),
                                             ("0x10", 16), (".5", 0.5), ("1_000", 1000), ("'1e-3'", "1e-3"), ("e5", "e5")])
def test_numbers_as_researchers_write_them(text: str, value: object) -> None:
    """YAML 1.1 reads ``1e-3`` as a string (it wants a dot and a signed exponent); the reader, as YAML 1.2
    and JSON, as a float.  A quoted one stays a string."""
    read = load_yaml(f"x: {text}\nlist: [{text}]\n", "f.yaml")
    assert read == {"x": value, "list": [value]} and type(read["x"]) is type(value)


HOSTILE_YAML = {
    "duplicate-key": ("a: 1\nb: 2\na: 3\n", "f.yaml holds the key 'a' twice in one mapping (line 3)"),
    "control-character": ("a: \x07\n", "f.yaml is not valid YAML: unacceptable character #x0007"),
    "nested": ("a: " + "[" * 40 + "]" * 40 + "\n", "f.yaml nests deeper than 32 levels"),
    "alias-bomb": ("a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join([f'*{chr(97 + i)}'] * 10)}]\n" for i in range(5)),
        "f.yaml holds more than 100000 values"),
    "not-yaml": ("a: [1, 2\n", "f.yaml is not valid YAML:"),
}


@pytest.mark.parametrize(("text", "message"), HOSTILE_YAML.values(), ids=HOSTILE_YAML.keys())
def test_hostile_yaml_is_one_line_naming_the_file(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "f.yaml"
    path.write_text(text)
    with pytest.raises(FileProblem) as raised:
        load_yaml_file(path)
    assert str(raised.value).startswith(message.replace("f.yaml", str(path))) and "\n" not in str(raised.value)


HOSTILE_JSON = {
    "duplicate-key": ('{"a": 1, "a": 2}', "f.json holds the key 'a' twice in one object"),
    "nested-past-python": ("[" * 100_000 + "]" * 100_000, "f.json nests deeper than 32 levels"),
    "nested": ("[" * 33 + "]" * 33, "f.json nests deeper than 32 levels"),
    "cut": ('{"a": [1, 2', "f.json is not valid JSON ("),
    "binary": ("\udcff", "f.json is not a text file"),
    "huge-integer": ("1" * 5000, "f.json is not valid JSON ("),
}


@pytest.mark.parametrize(("text", "message"), HOSTILE_JSON.values(), ids=HOSTILE_JSON.keys())
def test_hostile_json_is_one_line_naming_the_file(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "f.json"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    with pytest.raises(FileProblem) as raised:
        read_json(path)
    assert str(raised.value).startswith(message.replace("f.json", str(path))) and "\n" not in str(raised.value)


def test_a_file_larger_than_the_limit_is_refused_unread(tmp_path: Path) -> None:
    path = tmp_path / "big.json"
    path.write_text("[" + "0," * 100 + "0]")
    with pytest.raises(FileProblem, match=f"^{path} is larger than 64 bytes"):
        read_text(path, limit=64)


def test_the_expected_kind_is_named(tmp_path: Path) -> None:
    with pytest.raises(FileProblem, match=r"^f.json must hold a list \(array\), got a mapping"):
        parse_json("{}", "f.json", list)


HEADER = "index,subset,plant,seed,policy,cost\r\n"
TABLES = {
    "empty": ("", "is empty"),
    "header-only": (HEADER, "holds a header and no rows"),
    "cut-inside-a-number": (HEADER + "0,test,test-0,0,oracle,1.5\r\n1,test,test-1,1,oracle,2.", "ends inside a row"),
    "short-row": (HEADER + "0,test,test-0,0,oracle\r\n", "line 2: 5 fields, the header has 6"),
    "missing-column": ("index,plant\r\n0,p\r\n", "lacks the column(s) seed, policy, cost"),
    "200-kB-field": (HEADER + f"0,test,{'x' * 200_000},0,oracle,1.5\r\n", "is not a valid table (field larger than field limit"),
    "stray-quote": (HEADER + '0,test,"test-0,0,oracle,1.5\r\n', "is not a valid table"),
}


@pytest.mark.parametrize(("text", "message"), TABLES.values(), ids=TABLES.keys())
def test_a_damaged_table_is_one_line_naming_the_file(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "per_plant.csv"
    path.write_text(text, newline="")
    with pytest.raises(FileProblem) as raised:
        read_csv(path, ("index", "plant", "seed", "policy", "cost"))
    assert str(raised.value).startswith(str(path)) and message in str(raised.value) and "\n" not in str(raised.value)


# ------------------------------------------------------------------------------------- writing
def test_a_full_disk_leaves_no_empty_file_and_names_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``deadtime evaluate``'s tables are written together: a full disk while writing the third leaves
    the earlier tables whole, no empty file, no temporary file, and one line naming it."""
    from agents.evaluation import report
    from agents.evaluation.stats import PolicyStats

    stats = {"all": [PolicyStats("oracle", 1, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)]}
    out = tmp_path / "eval"
    out.mkdir()
    (out / "results.json").write_text('{"earlier": true}\n')
    calls = []

    def fsync(descriptor: int) -> None:
        calls.append(descriptor)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", fsync)
    with pytest.raises(FileProblem, match=r"results.csv could not be written \(No space left on device\)"):
        report.write_tables(out, "DeadTime/PID-v3", 1, 0, stats, {}, {}, [{"index": 0, "cost": 1.0}], [])
    assert sorted(p.name for p in out.iterdir()) == ["results.json"]
    assert (out / "results.json").read_text() == '{"earlier": true}\n'


def test_a_failed_write_leaves_the_previous_file(tmp_path: Path) -> None:
    path = tmp_path / "a.txt"
    write_text(path, "old")

    def broken(handle) -> None:
        handle.write(b"half")
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(FileProblem, match=f"^{path} could not be written"):
        atomic_write_all({path: broken})
    assert path.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


# ------------------------------------------------------------------------------------- locking
def test_a_folder_is_held_by_one_run(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with folder_lock(out, "train"):
        assert (out / LOCK_NAME).is_file()
        with pytest.raises(FolderInUse, match=f"^{out} is in use by another deadtime train"), folder_lock(out, "train"):
            pass
        holder = subprocess.run([sys.executable, "-c", "import sys; from agents.files.lock import folder_lock\n"
                                 f"with folder_lock({str(out)!r}, 'sweep'): pass"], capture_output=True, text=True, check=False)
        assert holder.returncode == 1 and "is in use by another deadtime sweep" in holder.stderr
    assert not out.exists()  # created by the lock, left empty: removed
    out.mkdir()
    (out / "kept").write_text("x")
    with folder_lock(out, "train"):
        pass
    assert sorted(p.name for p in out.iterdir()) == ["kept"]


def test_a_lock_of_a_killed_run_does_not_block(tmp_path: Path) -> None:
    """The operating system releases the lock of a process that ends, however it ends."""
    out = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c", "import os, time; from agents.files.lock import folder_lock\n"
                               f"with folder_lock({str(out)!r}, 'train'):\n    print('held', flush=True); time.sleep(60)"],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        with pytest.raises(FolderInUse), folder_lock(out, "train"):
            pass
    finally:
        holder.kill()
        holder.wait()
    with folder_lock(out, "train"):
        pass


def test_a_second_training_on_one_out_is_refused(tmp_path: Path) -> None:
    """Two ``deadtime train`` on one ``--out``: the second is refused in one line, before it writes anything."""
    out = tmp_path / "run"
    with folder_lock(out, "train"):
        status, stdout, err = run("train", "--config", str(REPO / "configs" / "sac.yaml"), "--env", "DeadTime/PID-v3",
                                  "--out", str(out))
        assert (status, sorted(p.name for p in out.iterdir())) == (2, [LOCK_NAME])
    assert err == f"deadtime train: error: {out} is in use by another deadtime train (it holds the lock {LOCK_NAME}); " \
                  "wait for that run to end, or choose another --out\n"


def test_a_second_sweep_on_one_out_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    with folder_lock(out, "sweep"):
        status, _, err = run("sweep", "--config", str(REPO / "configs" / "sweeps" / "smoke.yaml"), "--out", str(out))
    assert status == 2 and err.count("\n") == 1 and f"{out} is in use by another deadtime sweep" in err


# ----------------------------------------------------------------------------------- regimes
def _per_plant(path: Path, rows: list[tuple]) -> None:
    path.mkdir(parents=True, exist_ok=True)
    lines = ["index,subset,plant,seed,policy,cost"] + [",".join(str(v) for v in row) for row in rows]
    (path / "per_plant.csv").write_text("\r\n".join(lines) + "\r\n", newline="")


def _sweep(root: Path, noise: float) -> Path:
    out = root / f"noise{noise}"
    out.mkdir(parents=True)
    (out / "sweep.yaml").write_text(f"name: n{noise}\nenv_kwargs: {{noise_std: {noise}}}\ntrials: []\n")
    env = out / "eval" / "FPPI-v2"
    _per_plant(env / "baselines", [(i, "test", f"test-{i}", i, name, level + 0.1 * i) for name, level in
                                   (("oracle", 1.0), ("rule-a", 3.0)) for i in range(4)])
    for seed in range(2):
        _per_plant(env / f"fixed-FPPI-v2-s{seed}", [(i, "test", f"test-{i}", i, "agent", 2.0 + 0.1 * i) for i in range(4)])
    return out


def _damage(path: Path, how: str) -> None:
    text = path.read_bytes().decode()
    lines = text.splitlines(keepends=True)
    if how == "cut-inside-a-number":
        path.write_text(text[:-4], newline="")
    elif how == "negative-cost":
        path.write_text(text.replace(",3.1\r\n", ",-3.1\r\n"), newline="")
    elif how == "nan-cost":
        path.write_text(text.replace(",3.1\r\n", ",nan\r\n"), newline="")
    elif how == "missing-row":
        path.write_text("".join(lines[:2] + lines[3:]), newline="")
    elif how == "empty":
        path.write_text("")
    elif how == "header-only":
        path.write_text(lines[0], newline="")
    elif how == "200-kB-field":
        path.write_text(text.replace("test-1,", "x" * 200_000 + ",", 1), newline="")


REGIME_DAMAGES = {
    "cut-inside-a-number": "ends inside a row",
    "negative-cost": "line 7: not a finite cost >= 0 of a plant ('-3.1')",
    "nan-cost": "line 7: not a finite cost >= 0 of a plant ('nan')",
    "missing-row": "policy 'oracle' lacks 1 of the 4 plants the others have",
    "empty": "is empty",
    "header-only": "holds a header and no rows",
    "200-kB-field": "is not a valid table (field larger than field limit",
}


@pytest.mark.parametrize(("how", "message"), REGIME_DAMAGES.items(), ids=REGIME_DAMAGES.keys())
def test_regimes_refuses_a_damaged_per_plant_table(tmp_path: Path, how: str, message: str) -> None:
    sweeps = [_sweep(tmp_path, 0.1), _sweep(tmp_path, 0.01)]
    table = sweeps[1] / "eval" / "FPPI-v2" / "baselines" / "per_plant.csv"
    _damage(table, how)
    status, out, err = run("regimes", *map(str, sweeps), "--x", "noise_std", "--resamples", "50", "--out", str(tmp_path / "r"))
    assert (status, out) == (2, "")
    assert err.count("\n") == 1 and err.startswith(f"deadtime regimes: error: {table}") and message in err, err
    assert not (tmp_path / "r").exists()


def test_regimes_refuses_env_kwargs_that_are_no_mapping(tmp_path: Path) -> None:
    sweeps = [_sweep(tmp_path, 0.1), _sweep(tmp_path, 0.01)]
    (sweeps[0] / "sweep.yaml").write_text("name: n\nenv_kwargs: 5\ntrials: []\n")
    status, _, err = run("regimes", *map(str, sweeps), "--x", "noise_std", "--out", str(tmp_path / "r"))
    assert status == 2 and err == (f"deadtime regimes: error: {sweeps[0] / 'sweep.yaml'}: env_kwargs must be a mapping of "
                                   "environment arguments, got 5\n")


def test_regimes_writes_its_outputs_together(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A full disk while writing the figure leaves neither the JSON nor the table (all or none)."""
    sweeps = [_sweep(tmp_path, 0.1), _sweep(tmp_path, 0.01)]
    real = os.fsync
    calls = []

    def fsync(descriptor: int) -> None:
        calls.append(descriptor)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(descriptor)

    monkeypatch.setattr(os, "fsync", fsync)
    status, _, err = run("regimes", *map(str, sweeps), "--x", "noise_std", "--resamples", "50", "--out", str(tmp_path / "r"))
    assert status == 2 and "regimes.png could not be written (No space left on device)" in err and err.count("\n") == 1
    assert list((tmp_path / "r").iterdir()) == []
    monkeypatch.setattr(os, "fsync", real)
    assert run("regimes", *map(str, sweeps), "--x", "noise_std", "--resamples", "50", "--out", str(tmp_path / "r"))[0] == 0
    assert sorted(p.name for p in (tmp_path / "r").iterdir()) == ["regimes.json", "regimes.md", "regimes.png"]
    assert all((tmp_path / "r" / name).stat().st_size > 0 for name in ("regimes.json", "regimes.md", "regimes.png"))


# ----------------------------------------------------------------------------- other records
def test_a_deeply_nested_line_of_the_evaluation_cache_is_not_trusted(tmp_path: Path) -> None:
    from agents.evaluation.cache import Cache

    path = tmp_path / "cache.jsonl"
    path.write_text("[" * 100_000 + "]" * 100_000 + "\n")
    cache = Cache(path)
    assert cache.entries == {}


def test_a_deeply_nested_checkpoint_manifest_is_damaged(tmp_path: Path) -> None:
    from agents.files.reader import DamagedFileError
    from agents.training.checkpoints import read_manifest

    path = tmp_path / "latest.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(DamagedFileError, match=f"^{path} is damaged: nests deeper than 32 levels"):
        read_manifest(path)


def test_ctrl_c_before_the_run_exists_advises_no_resume(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--resume --out DIR`` would fail on a folder without its ``config.yaml``: it is not advised there."""
    from agents.commands.train import _interrupted

    assert _interrupted(KeyboardInterrupt(), tmp_path / "nothing", "") == 130
    assert "--resume" not in capsys.readouterr().err
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "config.yaml").write_text("algorithm: SAC\n")
    assert _interrupted(KeyboardInterrupt(), tmp_path / "run", "") == 130
    assert capsys.readouterr().err.strip().endswith(f"deadtime train --out {tmp_path / 'run'} --resume")


def test_resume_without_checkpoints_of_a_trained_run_is_refused(tmp_path: Path) -> None:
    """Deleting ``checkpoints/`` and resuming must not silently start from step 0."""
    run_dir = tmp_path / "run"
    config = tmp_path / "a2c.yaml"
    config.write_text("default:\n  algorithm: A2C\n  env_id: Pendulum-v1\n  total_timesteps: 32\n  eval_freq: 0\n"
                      "  checkpoint_freq: 16\n  progress_bar: false\n  hyperparameters: {n_steps: 8}\n"
                      "  policy_kwargs: {net_arch: [4]}\n")
    status, _, err = run("train", "--config", str(config), "--out", str(run_dir))
    assert status == 0, err
    for path in (run_dir / "checkpoints").iterdir():
        path.unlink()
    (run_dir / "checkpoints").rmdir()
    status, _, err = run("train", "--out", str(run_dir), "--resume", "total_timesteps=64")
    assert status == 2 and err.count("\n") == 1, err
    assert f"{run_dir / 'checkpoints'} holds no checkpoint, but {run_dir / 'run.json'} records 32 trained steps" in err
