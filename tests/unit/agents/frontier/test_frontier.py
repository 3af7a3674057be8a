"""The frontier: risk per seed and union, the knob chosen per risk level, and ``deadtime frontier`` on a Python callable."""

import csv
import json
import sys
import textwrap
from types import SimpleNamespace

import numpy as np
import pytest

from agents.cli import main
from agents.evaluation.result import PolicyResult
from agents.frontier.families import KnobSelector
from agents.frontier.frontier import RISK_LEVELS, Family, frontier_table


def _result(cost: float, violates: bool) -> PolicyResult:
    return PolicyResult(cost, not violates, False, 1.0)


def test_risk_is_per_seed_then_averaged_and_the_union_is_beside_it():
    # two seeds, four plants: seed 0 violates on plant 0, seed 1 on plant 1 -> risk 1/4 per seed, union 2/4
    violates = {"a#0@0.0": [True, False, False, False], "a#1@0.0": [False, True, False, False],
                "a#0@1.0": [False] * 4, "a#1@1.0": [False] * 4}
    costs = {"a#0@0.0": 1.0, "a#1@0.0": 2.0, "a#0@1.0": 3.0, "a#1@1.0": 5.0}
    results = [{**{name: _result(costs[name], v[i]) for name, v in violates.items()}, "oracle": _result(0.5, False)}
               for i in range(4)]
    keys = {("a", 0.0): ["a#0@0.0", "a#1@0.0"], ("a", 1.0): ["a#0@1.0", "a#1@1.0"]}
    table = frontier_table([Family("a", "agent", (None, None))], [0.0, 1.0], results, keys, {"env_id": "x", "n": 4, "seed": 0})
    shipped, conservative = table["rows"]
    assert (shipped["risk"], shipped["risk_union"], shipped["mean_cost"]) == (0.25, 0.5, 1.5)
    assert (conservative["risk"], conservative["mean_cost"]) == (0.0, 4.0)
    # only s = 1 reaches the declared levels (all below 25%)
    assert table["chosen"]["a"] == {"0.5%": 1.0, "1%": 1.0, "2%": 1.0, "5%": 1.0}
    assert table["best"]["1%"] == {"rule": None, "learned": {"family": "a", "knob": 1.0, "mean_cost": 4.0, "risk": 0.0},
                                   "difference": None}


def test_the_matched_difference_is_paired_by_plant_with_seeds_random():
    from agents.frontier.statistics import crossed_variance

    rng = np.random.default_rng(0)
    learned = rng.normal(3.0, 1.0, size=(3, 6))
    rule = rng.normal(4.0, 1.0, size=6)
    results = [{**{f"l#{j}@0.0": _result(learned[j, i], False) for j in range(3)}, "r@0.0": _result(rule[i], False),
                "oracle": _result(1.0, False)} for i in range(6)]
    keys = {("l", 0.0): [f"l#{j}@0.0" for j in range(3)], ("r", 0.0): ["r@0.0"]}
    families = [Family("l", "agent", (None,) * 3), Family("r", "rule", ("r",))]
    table = frontier_table(families, [0.0], results, keys, {"env_id": "x", "n": 6, "seed": 0})
    difference = table["best"]["0.5%"]["difference"]
    assert difference == crossed_variance(learned - rule).to_dict()
    assert difference["estimate"] == pytest.approx(learned.mean() - rule.mean(), rel=1e-12)


def test_a_selector_knob_lowers_its_threshold():
    seen = []
    selector = SimpleNamespace(names=("bold", "safe"), threshold=0.2,
                               choices=lambda observation, threshold: seen.append(threshold) or np.array([0]))
    policy = SimpleNamespace(selector=selector, env_kwargs={}, rule_of=lambda choice: choice)
    assert KnobSelector("s", policy, 1.0).choose(np.zeros(3)) == "bold"
    assert seen == [pytest.approx(0.2 * np.exp(-1.0))]


POLICY = """
def policy(observation):
    return [0.0]
"""


@pytest.fixture()
def callable_module(tmp_path, monkeypatch):
    (tmp_path / "frontier_policy.py").write_text(textwrap.dedent(POLICY))
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop("frontier_policy", None)
    return tmp_path


def test_frontier_command_on_a_python_callable(callable_module, capsys):
    out = callable_module / "out"
    status = main(["frontier", "--env", "DeadTime/PID-v3", "--policies", "gorez-klan-mu-2,mine=frontier_policy:policy",
                   "--knobs=-0.5,0.5", "--n", "4", "--out", str(out)])
    assert status == 0
    assert {"frontier.md", "frontier.csv", "frontier.json", "frontier.png"} <= {p.name for p in out.iterdir()}
    result = json.loads((out / "frontier.json").read_text())
    rows = {(row["family"], row["knob"]): row for row in result["rows"]}
    assert set(rows) == {(f, k) for f in ("gorez-klan-mu-2", "mine") for k in (-0.5, 0.0, 0.5)}
    with open(out / "frontier.csv") as handle:
        assert len(list(csv.DictReader(handle))) == 6
    for knob in (-0.5, 0.0, 0.5):
        # the residual action 0 is the base rule's mu = 2 (PID-v3): the callable's family, moved through the
        # environment's design map, is the rule's family, designed by the rule: two paths, one frontier (up to
        # the float32 action: 2^-24 relative in the action, times log(p_max/p_0) ~ 5 in the parameter, ~ 3e-7)
        mine, rule = rows["mine", knob], rows["gorez-klan-mu-2", knob]
        assert mine["mean_cost"] == pytest.approx(rule["mean_cost"], rel=1e-6) and mine["risk"] == rule["risk"]
    for family, chosen in result["chosen"].items():
        for r, level in zip(RISK_LEVELS, chosen):
            allowed = [row for (f, _), row in rows.items() if f == family and row["risk"] <= r]
            knob = chosen[level]
            assert (knob is None) == (not allowed)
            if allowed:
                assert rows[family, knob]["mean_cost"] == min(row["mean_cost"] for row in allowed)
    assert "| mine | callable | 0 (shipped) |" in capsys.readouterr().out


@pytest.mark.parametrize("policies, knobs, message", [
    ("amigo-pid", "--knobs=a,b", "--knobs must be comma-separated numbers"),
    ("amigo-pid", "--knobs=9", "knobs must be finite numbers from -5 to 5"),
    ("no_such_module:policy", "--knobs=0", "cannot import 'no_such_module'"),
    ("frontier_policy:absent", "--knobs=0", "has no function 'absent'"),
    ("no-such-rule", "--knobs=0", "unknown rule"),
    ("x=nowhere/seed*", "--knobs=0", "matches no file"),
])
def test_bad_input_is_one_line(callable_module, capsys, policies, knobs, message):
    status = main(["frontier", "--env", "DeadTime/PID-v3", "--policies", policies, knobs, "--n", "2",
                   "--out", str(callable_module / "out")])
    error = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and message in error[-1] and "Traceback" not in "\n".join(error)
    assert not (callable_module / "out").exists()  # nothing written


@pytest.mark.parametrize("env_id, kwargs", [("DeadTime/PID-v3", {}), ("DeadTime/FPPI-v3", {"action": "parameter"}),
                                            ("DeadTime/MSP-v3", {})])
def test_a_learned_knob_multiplies_the_design_parameter(env_id, kwargs):
    from agents.environments import make_env
    from agents.evaluation.policies import CallablePolicy
    from agents.frontier.families import at_knob

    env = make_env(env_id, kwargs)
    observation, _ = env.reset(seed=3)
    unwrapped = env.unwrapped
    base = CallablePolicy("base", lambda observation: np.array([-0.1], dtype=np.float32))
    parameter = unwrapped.parameter_from_action(-0.1)
    for knob in (-0.3, 0.0, 0.4):
        action, _ = at_knob("x", base, knob, env).predict(observation)
        # float32 action: 2^-24 relative, times log(p_max/p_min) <= 10 in the log of the parameter
        assert unwrapped.parameter_from_action(float(action[-1])) == pytest.approx(parameter * np.exp(knob), rel=1e-5)


def test_deadtime_evaluate_takes_a_family_member(capsys):
    from agents.evaluation.policies import parse_policies

    assert [spec.name for spec in parse_policies("amigo-pid@0.5,simc-pi", "pid")] == ["amigo-pid@0.5", "simc-pi"]
    with pytest.raises(ValueError, match="must be a number"):
        parse_policies("amigo-pid@x", "pid")
