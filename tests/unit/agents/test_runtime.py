"""The thread defaults and the provenance every command shares (:mod:`agents.runtime`), and the one
environment factory (:mod:`agents.environments`)."""

from __future__ import annotations

import os
import re

import pytest

from agents.environments import make_env
from agents.evaluation.oracle_info import OracleInfo
from agents.runtime import REPO, THREAD_VARIABLES, git_commit, single_thread_defaults, versions


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
    assert env.unwrapped.mode == "agent" and env.unwrapped.budget == 2
    assert isinstance(make_env("DeadTime/PID-v0", oracle=True), OracleInfo)
    with pytest.raises(ValueError, match=r"unknown environment 'DeadTime/Nope-v0'.*known: DeadTime/FPPI-v0"):
        make_env("DeadTime/Nope-v0")
