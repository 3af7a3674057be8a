"""``deadtime analyze --plant JSON --controller JSON [--json]`` (agents.cli).

End to end through a subprocess (``python -m agents.cli``): a good loop prints one JSON object
with the figures of the Score section and the same numbers as ``envs.analysis.loop_analysis.analyze``; an
unstable loop is a result (``stable: false``, IAE ``null``); bad input prints exactly one line on
stderr naming the field, exits non-zero, never a traceback.  The many bad-input rows run
in-process through ``agents.cli.main`` (same code path, no interpreter start-up per row); any
exception escaping ``main`` fails them, as a traceback would.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from in_process import run_deadtime as _main

from envs.analysis.loop_analysis import analyze
from envs.systems.controllers import controller_from_dict
from envs.systems.plants import Plant

REPO = Path(__file__).resolve().parents[3]

FOPDT = {"num": [1.0], "den": [1.0, 1.0], "delay": 0.5}
PID_JSON = {"type": "pid", "kp": 1.0, "ti": 1.0, "td": 0.1, "n": 10}
UNSTABLE_PID = {"type": "pid", "kp": 8.0, "ti": 1.0}
REQUIRED_KEYS = {
    "stable", "ms", "mt", "gain_margin", "phase_margin_deg", "delay_margin", "iae_load", "iae_setpoint",
    "gain_crossover_frequency", "phase_crossover_frequency",
}


def _strict_json(text: str):
    """``json.loads`` that refuses the non-standard NaN/Infinity tokens."""
    def refuse(token):
        raise AssertionError(f"non-standard JSON token {token}")
    return json.loads(text, parse_constant=refuse)


def _cli(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run(
        [sys.executable, "-m", "agents.cli", *args], capture_output=True, text=True, env=env, cwd=REPO, timeout=120
    )


SUBPROCESS_CASES = {
    "json": ("--plant", json.dumps(FOPDT), "--controller", json.dumps(PID_JSON), "--json"),
    "unstable": ("--plant", json.dumps(FOPDT), "--controller", json.dumps(UNSTABLE_PID), "--json"),
    "bad-plant-delay": ("--plant", json.dumps({**FOPDT, "delay": -1.0}), "--controller", json.dumps(PID_JSON)),
    "bad-json": ("--plant", '{"num": [1.0], "den": [1, 1], ', "--controller", json.dumps(PID_JSON)),
}


@pytest.fixture(scope="module")
def runs() -> dict[str, subprocess.CompletedProcess]:
    """All subprocess runs at once (each pays ~3 s of interpreter, scipy and numba start-up)."""
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = {name: pool.submit(_cli, "analyze", *args) for name, args in SUBPROCESS_CASES.items()}
        return {name: future.result() for name, future in futures.items()}


@pytest.mark.slow  # the module's subprocess runs take ~8 s together
def test_json_output_is_one_object_with_the_score_figures(runs):
    run = runs["json"]
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""
    lines = run.stdout.strip().splitlines()
    assert len(lines) == 1
    result = _strict_json(lines[0])
    assert isinstance(result, dict) and REQUIRED_KEYS <= set(result)
    assert result["stable"] is True
    expected = analyze(Plant.from_dict(FOPDT), controller_from_dict(PID_JSON)).to_dict()
    for key in REQUIRED_KEYS:
        assert result[key] == pytest.approx(expected[key], rel=1e-12), key


def test_text_output_lists_the_figures():
    code, out, err = _main("analyze", "--plant", json.dumps(FOPDT), "--controller", json.dumps(PID_JSON))
    assert code == 0 and err == ""
    keys = {line.split()[0] for line in out.strip().splitlines()}
    assert REQUIRED_KEYS <= keys


@pytest.mark.slow  # the module's subprocess runs take ~8 s together
def test_unstable_loop_is_a_result_not_a_crash(runs):
    run = runs["unstable"]
    assert run.returncode == 0, run.stderr
    result = _strict_json(run.stdout)
    assert result["stable"] is False
    assert result["iae_load"] is None and result["iae_setpoint"] is None
    assert result["ms"] is None


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, field",
    [("bad-plant-delay", "delay"), ("bad-json", "--plant")],
)
def test_bad_input_gives_one_line_naming_the_field(runs, name, field):
    run = runs[name]
    assert run.returncode != 0
    assert run.stdout == ""
    assert "Traceback" not in run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1, run.stderr
    assert field in lines[0]


# ----------------------------------------------------------------------------- in-process rows
def _assert_one_line_error(code, out, err, field):
    assert code not in (0, None)
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert field in lines[0], lines[0]


BAD_PLANTS = {
    "improper": ({"num": [1.0, 2.0, 1.0], "den": [1.0, 1.0], "delay": 1.0}, "num"),
    "unstable": ({"num": [1.0], "den": [1.0, -1.0], "delay": 1.0}, "den"),
    "nan": ({"num": [float("nan")], "den": [1.0, 1.0], "delay": 1.0}, "num"),
    "negative-delay": ({**FOPDT, "delay": -0.1}, "delay"),
    "zero-gain": ({"num": [1.0, 0.0], "den": [1.0, 1.0], "delay": 1.0}, "num"),
    "two-integrators": ({"num": [1.0], "den": [1.0, 0.0, 0.0], "delay": 1.0}, "den"),
    "missing-key": ({"num": [1.0], "den": [1.0, 1.0]}, "delay"),
    "unknown-key": ({**FOPDT, "gain": 2}, "gain"),
    "not-an-object": ([1.0, 2.0], "plant"),
    "string-coefficient": ({**FOPDT, "num": ["1"]}, "num"),
}


@pytest.mark.parametrize("name", BAD_PLANTS)
def test_bad_plant_json(name):
    plant, field = BAD_PLANTS[name]
    text = json.dumps(plant, allow_nan=True)
    _assert_one_line_error(*_main("analyze", "--plant", text, "--controller", json.dumps(PID_JSON)), field)


BAD_CONTROLLERS = {
    "unknown-type": ({"type": "lambda", "kp": 1.0}, "type"),
    "unknown-key": ({**PID_JSON, "tau": 1.0}, "tau"),
    "missing-key": ({"type": "pid", "kp": 1.0}, "ti"),
    "nan": ({**PID_JSON, "kp": float("nan")}, "kp"),
    "negative-ti": ({**PID_JSON, "ti": -1.0}, "ti"),
    "fppi-missing-model-key": ({"type": "fppi", "model": {"gain": 1.0, "dead_time": 0.5}, "tr": 1.0}, "time_constant"),
    "msp-negative-tr": ({"type": "msp", "model": {"gain": 1.0, "dead_time": 0.5}, "tr": -1.0}, "tr"),
}


@pytest.mark.parametrize("name", BAD_CONTROLLERS)
def test_bad_controller_json(name):
    controller, field = BAD_CONTROLLERS[name]
    text = json.dumps(controller, allow_nan=True)
    _assert_one_line_error(*_main("analyze", "--plant", json.dumps(FOPDT), "--controller", text), field)


def test_invalid_controller_json_names_the_option():
    _assert_one_line_error(*_main("analyze", "--plant", json.dumps(FOPDT), "--controller", "{'type': 'pid'}"), "--controller")


def test_arguments_may_be_files(tmp_path):
    plant_file, controller_file = tmp_path / "plant.json", tmp_path / "controller.json"
    plant_file.write_text(json.dumps(FOPDT))
    controller_file.write_text(json.dumps(PID_JSON))
    code, out, err = _main("analyze", "--plant", str(plant_file), "--controller", str(controller_file), "--json")
    assert code == 0 and err == ""
    assert _strict_json(out)["stable"] is True


def test_integrating_plant_with_msp(tmp_path):
    plant = {"num": [1.0], "den": [0.5, 1.0, 0.0], "delay": 1.0}
    controller = {"type": "msp", "model": {"gain": 1.0, "dead_time": 1.5}, "tr": 1.5, "extension": True}
    code, out, err = _main("analyze", "--plant", json.dumps(plant), "--controller", json.dumps(controller), "--json")
    assert code == 0, err
    result = _strict_json(out)
    assert result["stable"] is True and result["iae_load"] > 0 and result["delay_margin"] > 0


def test_controller_type_that_is_not_a_name():
    """Regression: ``"type": ["pid"]`` used to end in a TypeError traceback."""
    controller = json.dumps({"type": ["pid"], "kp": 1.0, "ti": 1.0})
    _assert_one_line_error(*_main("analyze", "--plant", json.dumps(FOPDT), "--controller", controller), "type")


HUGE = "1" * 400  # a valid JSON integer that does not fit in a float


@pytest.mark.parametrize(
    "plant, controller, field",
    [
        (f'{{"num": [1], "den": [1, 1], "delay": {HUGE}}}', json.dumps(PID_JSON), "delay"),
        (f'{{"num": [{HUGE}], "den": [1, 1], "delay": 1}}', json.dumps(PID_JSON), "num"),
        (json.dumps(FOPDT), f'{{"type": "pid", "kp": {HUGE}, "ti": 1}}', "kp"),
    ],
    ids=["delay", "num", "kp"],
)
def test_huge_integer_literal(plant, controller, field):
    _assert_one_line_error(*_main("analyze", "--plant", plant, "--controller", controller), field)


def test_missing_option_is_one_line():
    _assert_one_line_error(*_main("analyze", "--plant", json.dumps(FOPDT)), "--controller")
