"""``deadtime tune --rule NAME --plant JSON [--model JSON] [--json]`` and ``--list`` (agents.cli).

In-process through ``agents.cli.main`` (the console script's code path); one subprocess run checks
that an error reaches the shell as one line and a non-zero exit, without a traceback.  The
controller JSON that ``tune --json`` prints is fed to ``analyze`` (the two compose) and must give
the same analysis.
"""

from __future__ import annotations

import json
import math
import re
import os
import subprocess
import sys
from pathlib import Path

import pytest
from in_process import run_deadtime as run

from agents.cli import main
from baselines.rules.pid import ultimate_point, zn_ultimate_pi
from baselines.rules.registry import RULES
from envs.identification.models import model_from_dict
from envs.systems.plants import Plant

REPO = Path(__file__).resolve().parents[3]
STABLE = {"num": [1.0], "den": [10.0, 1.0], "delay": 5.0}
INTEGRATING = {"num": [1.0], "den": [2.0, 1.0, 0.0], "delay": 5.0}
SECOND_ORDER = {"num": [1.0], "den": [20.0, 12.0, 1.0], "delay": 5.0}


def tune_json(rule: str, plant: dict | None, model: dict | None = None, status: int = 0) -> dict:
    """``tune --json``; with ``status=3`` the loop's problem is the one line on stderr."""
    args = ["tune", "--rule", rule, "--json"]
    if plant is not None:
        args += ["--plant", json.dumps(plant)]
    if model is not None:
        args += ["--model", json.dumps(model)]
    code, out, err = run(*args)
    assert code == status, err
    lines = out.strip().splitlines()
    assert len(lines) == 1
    result = json.loads(lines[0])
    assert err == ("" if status == 0 else f"deadtime tune: {result['problem']}\n")
    return result


def test_list_names_every_rule_with_its_citation():
    status, out, _ = run("tune", "--list")
    assert status == 0
    lines = out.strip().splitlines()
    assert [line.split()[0] for line in lines] == list(RULES)
    assert all(rule.citation in line for rule, line in zip(RULES.values(), lines))
    status, out, _ = run("tune", "--list", "--json")
    assert [r["name"] for r in json.loads(out)] == list(RULES)


@pytest.mark.parametrize(
    "rule, plant, status",
    [("simc-pi", STABLE, 0), ("gorez-klan-mu-2", STABLE, 3), ("fppi-eq28", SECOND_ORDER, 0), ("msp-eq43", INTEGRATING, 0),
     ("zn-ultimate-pid", INTEGRATING, 3)],
)
def test_tune_json_composes_with_analyze(rule, plant, status):
    """Status 3: stable loops outside ``Ms <= 2`` (the identified SOPDT of an FOPDT plant, Gorez-Klan eq. 2-8)."""
    result = tune_json(rule, plant, status=status)
    assert result["rule"] == rule and result["citation"] == RULES[rule].citation
    assert result["controller"]["type"] == RULES[rule].controller
    status, out, err = run("analyze", "--plant", json.dumps(plant), "--controller", json.dumps(result["controller"]), "--json")
    assert status == 0, err
    assert json.loads(out) == result["analysis"]
    assert result["analysis"]["stable"] is True


def test_parameter_is_the_rules_mu():
    assert tune_json("gorez-klan-mu-1.5", STABLE, status=3)["parameter"] == 1.5
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
    result = tune_json(rule, plant, model, status=3 if rule == "zn-ultimate-pi" else 0)
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
    "missing-rule": (("--plant", json.dumps(STABLE)), "--rule and --plant or --model are required (or --list)"),
    "missing-plant-and-model": (("--rule", "simc-pi"), "--rule and --plant or --model are required (or --list)"),
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


# ------------------------------------------------------------- a user's own model
USER_FOPDT = {"type": "fopdt", "gain": 2.5, "time_constant": 12, "dead_time": 4}


def test_tune_with_a_model_only_analyses_the_model():
    """No ``--plant``; SIMC on ``2.5 e^{-4s}/(12 s + 1)``: ``K_c = T/(K 2 L) = 0.6``,
    ``T_i = min(T, 8 L) = 12`` (Skogestad 2003), analysed on that FOPDT (python-control-free closed
    form: the loop is ``e^{-4s}/(8 s)``, gain margin ``2 pi/2 = pi``)."""
    result = tune_json("simc-pi", None, USER_FOPDT)
    assert result["controller"] == {"type": "pid", "kp": 0.6, "ti": 12.0, "td": 0.0, "n": 10.0}
    assert Plant.from_dict(result["plant"]) == Plant.from_time_constants(2.5, [12.0], 4.0)
    assert result["analysis"]["stable"] is True and result["problem"] is None
    assert result["analysis"]["gain_margin"] == pytest.approx(math.pi, rel=1e-9)


EXACT_FOPDT_PROBLEMS = {
    "zn-step-pi": "Ms = 2.566 > 2", "zn-step-pid": "Ms = 3.901 > 2", "zn-ultimate-pi": "Ms = 2.326 > 2",
    "zn-ultimate-pid": "Ms = 2.578 > 2", "cohen-coon-pi": "Ms = 3.508 > 2", "cohen-coon-pid": "Ms = 4.289 > 2",
    "chr-setpoint-20-pid": "Ms = 2.459 > 2", "chr-load-0-pid": "Ms = 2.221 > 2", "chr-load-20-pi": "Ms = 2.17 > 2",
    "chr-load-20-pid": "Ms = 3.173 > 2", "imc-pid": "Ms = 2.142 > 2", "gorez-klan-mu-1.3": "Ms = 2.184 > 2",
}


@pytest.mark.parametrize("rule", [name for name, r in RULES.items() if r.controller in ("pid", "pid-series") and r.plants != "integrating"])
def test_every_pid_rule_on_an_exact_fopdt_model_closes_a_stable_loop_or_exits_3(rule):
    """The model is read in the rule's own form (no moment-fitted SOPDT, on which ``simc-pid``,
    ``haalman-pid`` and the ``mu`` rules would close loops with 4-6 unstable poles here); a
    stable loop outside ``Ms <= 2`` exits 3 naming the constraint."""
    problem = EXACT_FOPDT_PROBLEMS.get(rule)
    status, out, err = run("tune", "--rule", rule, "--model", json.dumps(USER_FOPDT), "--json")
    result = json.loads(out)
    assert result["analysis"]["stable"] is True
    if problem is None:
        assert (status, err) == (0, "")
    else:
        assert status == 3
        assert err == f"deadtime tune: {rule} gives a loop outside the constraints on the plant: {problem}\n"


def test_mu_rules_read_a_fopdt_model_as_the_sopdt_with_no_second_lag():
    """Gorez-Klan eq. 3-11 with ``T_2 = 0``, ``D_2 = L``: ``K_p = T_1/(mu K D_2)``, ``T_d = 0``."""
    result = tune_json("gorez-klan-mu-2", None, USER_FOPDT)
    assert result["controller"]["kp"] == pytest.approx(12 / (2 * 2.5 * 4), rel=1e-12)
    assert result["controller"]["ti"] == 12.0 and result["controller"]["td"] == 0.0


def test_an_unstable_loop_is_one_line_and_exit_3():
    """A model whose dead time is a third of the plant's: ZN's step PID is unstable on the plant."""
    plant = {"num": [2.5], "den": [12.0, 1.0], "delay": 12.0}
    status, out, err = run("tune", "--rule", "zn-step-pid", "--plant", json.dumps(plant), "--model", json.dumps(USER_FOPDT))
    assert status == 3 and "stable" in out
    assert err == "deadtime tune: zn-step-pid gives an unstable loop on the plant (2 closed-loop poles in the right half plane)\n"


NUMBER = r"[0-9.]+e-[0-9]+"


@pytest.mark.parametrize(
    "rule, model, error",
    [("fppi-eq28", USER_FOPDT, "T_f_bar"), ("msp-eq43", {"type": "integrating", "gain": 0.5, "dead_time": 4}, "A")],
    ids=["fppi-eq28", "msp-eq43"],
)
def test_a_degenerate_tr_from_an_exact_model_is_refused_with_exit_3(rule, model, error):
    """The line exactly, but for its numbers, which are rounding noise of an exact model's zero
    model error (here ``T_f_bar`` about 6e-14 and ``T_r = 8.3e-7``; ``A`` about 3e-15 and
    ``T_r`` about 1e-14), hence only required to be below ``1e-5``."""
    status, out, err = run("tune", "--rule", rule, "--model", json.dumps(model))
    floor = {"fppi-eq28": "0.08", "msp-eq43": "0.14"}[rule]
    pattern = (rf"deadtime tune: {rule} gives T_r = ({NUMBER}) = ({NUMBER}) L_n, below the floor {floor} L_n: the model "
               rf"error \({error} = ({NUMBER})\) is about zero, as for an exact model, and below the floor even the "
               r"model's own loop has DM < 0.2 L_n\n")
    match = re.fullmatch(pattern, err)
    assert (status, out) == (3, "") and match, err
    assert all(float(x) < 1e-5 for x in match.groups())


@pytest.mark.parametrize("controller, floor", [("fppi", 0.0790), ("msp", 0.1394)])
def test_tr_floors_are_the_exact_model_delay_margin(controller, floor):
    """At ``TR_FLOORS`` the loop around the exact model keeps ``DM >= 0.2 L_n``; at the measured
    ``T_r/L_n`` (four digits) it is 0.2 to the rounding of the digits (the DM grows about 3.5 L_n
    per unit of ``T_r/L_n`` there)."""
    from baselines.rules.tune import TR_FLOORS
    from envs.analysis.loop_analysis import plant_margins
    from envs.design import fppi_design, msp_design
    from envs.identification.models import FOPDTModel, IntegratingModel

    if controller == "fppi":
        model = FOPDTModel(2.5, 12.0, 4.0)
        margin = lambda r: plant_margins(model.plant(), fppi_design(model, r * 4.0)).delay_margin / 4.0  # noqa: E731
    else:
        model = IntegratingModel(0.5, 4.0)
        margin = lambda r: plant_margins(model.plant(), msp_design(model, r * 4.0)).delay_margin / 4.0  # noqa: E731
    assert margin(TR_FLOORS[controller]) >= 0.2
    assert margin(floor) == pytest.approx(0.2, abs=5e-4)


def test_tune_takes_a_transfer_function_and_delay_or_a_dict():
    import control

    from baselines.rules.tune import tune

    by_tf = tune("simc-pi", (control.tf([2.5], [12.0, 1.0]), 4.0), USER_FOPDT)
    by_dict = tune("simc-pi", {"num": [2.5], "den": [12.0, 1.0], "delay": 4.0}, USER_FOPDT)
    assert by_tf.controller == by_dict.controller
    assert by_tf.analysis.margins.ms == by_dict.analysis.margins.ms


# ------------------------------------------------------------------ exact messages
@pytest.mark.parametrize(
    "args, line",
    [
        (("--rule", "simc-pi", "--plant", "plant.json"), "deadtime tune: error: --plant: no such file 'plant.json' (nor is it JSON)"),
        (("--rule", "simc-pi", "--model", json.dumps({**USER_FOPDT, "dead_time": 0})),
         "deadtime tune: error: simc_pi needs dead_time > 0 (its default tau_c is the dead time), got 0.0"),
        (("--rule", "imc-pi", "--model", json.dumps({**USER_FOPDT, "dead_time": 0})),
         "deadtime tune: error: imc_pi needs dead_time > 0 (its default lambda is 1.7 times the dead time), got 0.0"),
    ],
    ids=["missing-plant-file", "simc-zero-dead-time", "imc-zero-dead-time"],
)
def test_messages_are_exact(args, line):
    assert run("tune", *args) == (2, "", line + "\n")


def test_analysis_offers_the_flat_names_of_the_json():
    """``t.analysis.ms`` as the JSON's ``ms`` (as well as ``t.analysis.margins.ms``)."""
    from baselines.rules.tune import tune

    analysis = tune("simc-pi", model=USER_FOPDT).analysis
    flat = analysis.to_dict()
    for name in ("ms", "mt", "gain_margin", "phase_margin_deg", "delay_margin", "iae_load", "iae_setpoint"):
        assert getattr(analysis, name) == flat[name]


def test_a_users_envs_folder_shadowing_ours_is_one_line(tmp_path):
    """An ``envs/`` folder earlier on ``sys.path`` (here by PYTHONPATH) is named."""
    (tmp_path / "envs").mkdir()
    (tmp_path / "envs" / "__init__.py").write_text("")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(REPO)])}
    done = subprocess.run([sys.executable, "-m", "agents.cli", "--version"], check=False, capture_output=True,
                          text=True, env=env, cwd=tmp_path, timeout=120)
    assert done.returncode == 2
    assert done.stderr == (f"deadtime: error: the package 'envs' is imported from {tmp_path / 'envs'}, not from "
                           f"deadtime-gym's {REPO / 'envs'}: a folder named envs in the working directory or on "
                           "sys.path shadows ours; rename it or run elsewhere\n")
