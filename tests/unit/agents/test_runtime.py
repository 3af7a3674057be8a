"""The thread defaults and the provenance every command shares (:mod:`agents.runtime`), and the one
environment factory (:mod:`agents.environments`)."""

from __future__ import annotations

import os
import re

import pytest

from agents.environments import make_env
from agents.evaluation.oracle_info import OracleInfo
from agents.runtime import REPO, THREAD_VARIABLES, git_commit, single_thread_defaults, versions
from envs.interface import tuning_env_of


def test_single_thread_defaults_keep_the_users_setting(monkeypatch):
    for name in THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    single_thread_defaults()
    assert {name: os.environ[name] for name in THREAD_VARIABLES} == {**dict.fromkeys(THREAD_VARIABLES, "1"), "OMP_NUM_THREADS": "3"}


def test_the_makefile_exports_the_same_thread_defaults():
    """The Makefile's exports are :data:`THREAD_VARIABLES` with the default 1, nothing more, nothing less."""
    makefile = (REPO / "Makefile").read_text()
    exported = dict(re.findall(r"^export (\w+) \?= (\S+)$", makefile, flags=re.M))
    assert exported == dict.fromkeys(THREAD_VARIABLES, "1")


def test_provenance_names_the_commit_and_the_versions():
    commit = git_commit()
    assert commit is None or re.fullmatch(r"[0-9a-f]{40}(-dirty)?", commit)
    found = versions(("numpy", "no-such-distribution"))
    assert set(found) == {"python", "numpy", "no-such-distribution"} and found["no-such-distribution"] == "not installed"


def test_the_factory_registers_refuses_unknown_ids_and_wraps_the_oracle():
    env = make_env("DeadTime/FPPI-v0", {"experiments": "agent", "budget": 2})
    assert tuning_env_of(env).mode == "agent" and tuning_env_of(env).budget == 2
    assert isinstance(make_env("DeadTime/PID-v0", oracle=True), OracleInfo)
    with pytest.raises(ValueError, match=r"unknown environment 'DeadTime/Nope-v0'.*known: DeadTime/FPPI-v0"):
        make_env("DeadTime/Nope-v0")


def _python(code: str, **variables: str) -> tuple[str, str]:
    """Run ``code`` in a fresh interpreter with none of the thread variables but ``variables``."""
    import subprocess
    import sys

    environment = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES} | variables
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=environment, check=True, cwd=REPO)
    return done.stdout.strip(), done.stderr


THREADS = "import os, torch; print(torch.get_num_threads(), *(os.environ.get(v) for v in {variables!r}))"


def test_importing_agents_applies_the_thread_defaults():
    """Importing agents before torch (any script that trains through stable-baselines3's API or calls
    evaluate): torch and the other libraries get one thread, as under ``deadtime``."""
    out, err = _python("import agents; " + THREADS.format(variables=THREAD_VARIABLES))
    assert out == "1 1 1 1 1" and "RuntimeWarning" not in err


def test_the_users_threads_are_kept():
    """torch's threads follow MKL_NUM_THREADS, else OMP_NUM_THREADS; a variable the user set is kept,
    and torch imported first with threads the user chose is no reason for a warning."""
    mine = {"MKL_NUM_THREADS": "2", "OMP_NUM_THREADS": "2"}
    out, err = _python("import agents; " + THREADS.format(variables=tuple(mine)), **mine)
    assert out == "2 2 2" and "RuntimeWarning" not in err
    out, err = _python("import torch; import agents; " + THREADS.format(variables=()), OMP_NUM_THREADS="2")
    assert out == "2" and "RuntimeWarning" not in err


def test_torch_imported_first_gets_one_warning():
    out, err = _python("import torch; default = torch.get_num_threads(); import agents, agents.evaluation.evaluate; "
                       "print(default, torch.get_num_threads())")
    default, now = out.split()
    if default == "1":
        pytest.skip("torch runs one thread by default here (one core)")
    assert now == default
    assert err.count("RuntimeWarning: torch was imported before agents") == 1 and "torch.set_num_threads(1)" in err
