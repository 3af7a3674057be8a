"""A user's process (``deadtime process --process module:factory``) that faults: an actuator call, a
measurement or a reset that raises, units that are no units, a sample time that would make a run of
unbounded length.  One line, a non-zero exit, no traceback; a fault during the policies' tests stops
those tests, and their rows keep what was measured before it."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest
from in_process import run_deadtime


FAULTY = """
from envs.process.tclab_process import TCLabProcess

class Faulty(TCLabProcess):
    '''Raises in {call} from sample {after} after every reset but the first {healthy}.'''

    resets = 0

    def reset(self, seed):
        if '{call}' == 'reset' and self.resets > {healthy}:
            raise OSError('the serial port is gone')
        super().reset(seed)
        self.resets += 1
        self.samples = 0

    def apply(self, control, load=0.0):
        if '{call}' == 'apply' and self.resets > {healthy} and self.samples >= {after}:
            raise RuntimeError('the heater does not answer')
        super().apply(control, load)
        self.samples += 1

def make():
    return Faulty()

def text_units():
    process = TCLabProcess()
    process.units = 'degC'
    return process

def tiny_sample_time():
    process = TCLabProcess()
    process.sample_time = 1e-300
    return process

def huge_settling_time():
    process = TCLabProcess()
    process.settling_time = 1e300
    return process
"""


def _module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, **fields: object) -> str:
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(FAULTY.format(**fields)))
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    return name


def run(*args: str) -> tuple[int, str, str]:
    return run_deadtime("process", *args)


@pytest.mark.parametrize(("factory", "message"), [
    ("text_units", "process.units must be a Units (names of the time, input, output and load units), got 'degC'"),
    ("tiny_sample_time", "process.settling_time 900 must be at most 100000 sample times (1e-295;"),
    ("huge_settling_time", "process.settling_time 1e+300 must be at most 100000 sample times (100000;"),
])
def test_an_invalid_process_is_refused_before_it_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, factory: str,
                                                      message: str) -> None:
    module = _module(tmp_path, monkeypatch, "invalid_processes", call="", after=0, healthy=0)
    status, printed, err = run("--process", f"{module}:{factory}")
    assert (status, printed) == (2, "")
    assert err.count("\n") == 1 and err.startswith(f"deadtime process: error: --process: {module}:{factory}() returned no "
                                                   f"valid process: {message}"), err


@pytest.mark.parametrize(("call", "message"), [
    ("apply", "deadtime process: error: settle: the process's apply() raised RuntimeError: the heater does not answer at t = 0 s"),
    ("reset", "deadtime process: error: the process's reset(0) raised OSError: the serial port is gone"),
])
def test_a_fault_during_the_identification_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, call: str,
                                                       message: str) -> None:
    module = _module(tmp_path, monkeypatch, f"faulty_{call}_at_once", call=call, after=0, healthy=-1)
    status, printed, err = run("--process", f"{module}:make")
    assert (status, printed) == (2, "")
    assert err == message + "\n"


def test_an_actuator_fault_during_the_tests_stops_them_keeping_what_was_measured(tmp_path: Path,
                                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    module = _module(tmp_path, monkeypatch, "faulty_apply_later", call="apply", after=1300, healthy=1)
    status, printed, err = run("--process", f"{module}:make", "--policies", "simc-pi", "--json")
    assert status == 0, err
    for row in json.loads(printed)["policies"]:
        assert row["stopped"].startswith("set-point test: the process's apply() raised RuntimeError: the heater does not "
                                         "answer at t = 140 s")
        assert row["cost"] > 20  # graded as a stopped test
