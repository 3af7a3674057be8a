"""``deadtime tune --rule NAME --plant JSON [--model JSON] [--json]`` and ``--list`` (agents.cli).

In-process through ``agents.cli.main`` (the console script's code path); one subprocess run checks
that an error reaches the shell as one line and a non-zero exit, without a traceback.  The
controller JSON that ``tune --json`` prints is fed to ``analyze`` (the two compose) and must give
the same analysis.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from agents.cli import main
from baselines.pid_rules import ultimate_point, zn_ultimate_pi
from baselines.rules import RULES
from envs.identification import model_from_dict

REPO = Path(__file__).resolve().parents[2]
STABLE = {"num": [1.0], "den": [10.0, 1.0], "delay": 5.0}
INTEGRATING = {"num": [1.0], "den": [2.0, 1.0, 0.0], "delay": 5.0}


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        status = main(list(args))
    return status, out.getvalue(), err.getvalue()


def tune_json(rule: str, plant: dict, model: dict | None = None) -> dict:
    args = ["tune", "--rule", rule, "--plant", json.dumps(plant), "--json"]
    if model is not None:
        args += ["--model", json.dumps(model)]
    status, out, err = run(*args)
    assert status == 0, err
    assert err == ""
    lines = out.strip().splitlines()
    assert len(lines) == 1
    return json.loads(lines[0])


def test_list_names_every_rule_with_its_citation():
    status, out, _ = run("tune", "--list")
    assert status == 0
    lines = out.strip().splitlines()
    assert [line.split()[0] for line in lines] == list(RULES)
    assert all(rule.citation in line for rule, line in zip(RULES.values(), lines))
    status, out, _ = run("tune", "--list", "--json")
    assert [r["name"] for r in json.loads(out)] == list(RULES)


@pytest.mark.parametrize(
    "rule, plant",
    [("simc-pi", STABLE), ("gorez-klan-mu-2", STABLE), ("fppi-eq28", STABLE), ("msp-eq43", INTEGRATING),
     ("zn-ultimate-pid", INTEGRATING)],
)
def test_tune_json_composes_with_analyze(rule, plant):
    result = tune_json(rule, plant)
    assert result["rule"] == rule and result["citation"] == RULES[rule].citation
    assert result["controller"]["type"] == RULES[rule].controller
    status, out, err = run("analyze", "--plant", json.dumps(plant), "--controller", json.dumps(result["controller"]), "--json")
    assert status == 0, err
    assert json.loads(out) == result["analysis"]
    assert result["analysis"]["stable"] is True


def test_parameter_is_the_rules_mu():
    assert tune_json("gorez-klan-mu-1.5", STABLE)["parameter"] == 1.5
    assert tune_json("simc-pi", STABLE)["parameter"] is None


@pytest.mark.parametrize(
    "rule, plant, model",
    [
        ("simc-pi", STABLE, {"type": "fopdt", "gain": 1, "time_constant": 10, "dead_time": 5}),
        ("gorez-klan-mu-2", STABLE, {"type": "sopdt", "gain": 1, "time_constants": [8, 2], "dead_time": 5}),
        ("zn-ultimate-pi", STABLE, {"type": "fopdt", "gain": 1, "time_constant": 10, "dead_time": 5}),
        ("fppi-eq28", STABLE, {"type": "fopdt", "gain": 1, "time_constant": 9, "dead_time": 6}),
        ("msp-tr-tn", INTEGRATING, {"type": "integrating", "gain": 1, "dead_time": 5, "time_constant": 2}),
        ("msp-eq43", INTEGRATING, {"type": "integrating", "gain": 1, "dead_time": 6.5}),
    ],
    ids=["simc-fopdt", "mu-sopdt", "zn-ultimate-fopdt", "fppi-fopdt", "msp-tr-tn-integrating", "msp-eq43-integrating"],
)
def test_model_argument_is_what_the_rule_reads(rule, plant, model):
    result = tune_json(rule, plant, model)
    inputs = result["inputs"]
    if model["type"] == "integrating":
        assert inputs["integrating_model"]["dead_time"] == model["dead_time"] + (model.get("time_constant") or 0)
    else:
        assert inputs[model["type"]] == model
    if rule == "simc-pi":  # SIMC on K e^{-5s}/(10 s + 1): K_c = T/(K 2 L), T_i = min(T, 8 L)
        assert result["controller"]["kp"] == pytest.approx(1.0) and result["controller"]["ti"] == pytest.approx(10.0)
    if rule == "zn-ultimate-pi":  # the exact ultimate point of the given FOPDT, not of the plant's experiments
        expected = zn_ultimate_pi(*ultimate_point(model_from_dict(model)))
        assert result["controller"] == json.loads(json.dumps(expected.to_dict()))
    if rule == "msp-tr-tn":
        assert result["controller"]["tr"] == 2.0
    if rule == "fppi-eq28":
        assert result["inputs"]["mismatch_time"] > 0.5  # the model is wrong by one time unit of dead time


BAD = {
    "unknown-rule": (("--rule", "nope", "--plant", json.dumps(STABLE)), "unknown rule 'nope'"),
    "bad-plant": (("--rule", "simc-pi", "--plant", json.dumps({"num": [1], "den": [1, 1]})), "plant is missing key 'delay'"),
    "bad-plant-json": (("--rule", "simc-pi", "--plant", '{"num": [1'), "--plant is not valid JSON"),
    "bad-model": (("--rule", "simc-pi", "--plant", json.dumps(STABLE), "--model", '{"type": "fopdt", "gain": 1}'),
                  "model is missing key"),
    "bad-model-type": (("--rule", "simc-pi", "--plant", json.dumps(STABLE), "--model", '{"type": "third-order"}'),
                       "model.type must be one of"),
    "negative-model-dead-time": (
        ("--rule", "simc-pi", "--plant", json.dumps(STABLE), "--model",
         '{"type": "fopdt", "gain": 1, "time_constant": 1, "dead_time": -1}'), "model.dead_time must be >= 0"),
    "model-of-other-kind": (("--rule", "simc-pi", "--plant", json.dumps(STABLE), "--model",
                             '{"type": "integrating", "gain": 1, "dead_time": 3}'), "does not fit the plant"),
    "stable-rule-integrating-plant": (("--rule", "gorez-klan-mu-2", "--plant", json.dumps(INTEGRATING)),
                                      "rule gorez-klan-mu-2 is for self-regulating plants"),
    "integrating-rule-stable-plant": (("--rule", "msp-eq43", "--plant", json.dumps(STABLE)),
                                      "rule msp-eq43 is for integrating plants"),
    "missing-rule": (("--plant", json.dumps(STABLE)), "--rule and --plant are required"),
}


@pytest.mark.parametrize("case", BAD)
def test_bad_input_is_one_line_and_exit_2(case):
    args, message = BAD[case]
    status, out, err = run("tune", *args)
    assert status == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1
    assert err.startswith("deadtime tune: error: ") and message in err


def test_error_reaches_the_shell_without_traceback():
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, "-m", "agents.cli", "tune", "--rule", "nope", "--plant", json.dumps(STABLE)],
                          check=False, capture_output=True, text=True, env=env, cwd=REPO, timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [("deadtime tune: error: unknown rule 'nope'; `deadtime tune --list` names the "
                                                 f"{len(RULES)} rules")]
    assert "Traceback" not in done.stderr
