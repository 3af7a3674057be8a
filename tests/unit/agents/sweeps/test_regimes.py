"""``deadtime regimes`` (:mod:`agents.sweeps.regimes`) on synthetic sweep outputs: the figures against
a direct computation, the behaviour of an agent replayed by hand, and bad input."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from in_process import run_deadtime as _run

from agents.evaluation.seed_statistics import paired_difference
from agents.sweeps.regimes import behaviour, compare_regimes

PLANTS = 6


def _per_plant(path: Path, costs: dict[str, np.ndarray]) -> None:
    path.mkdir(parents=True, exist_ok=True)
    with (path / "per_plant.csv").open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(["index", "subset", "plant", "seed", "policy", "cost"])
        for name, values in costs.items():
            for i, value in enumerate(values):
                writer.writerow([i, "test", f"test-{i}", i, name, value])


def _sweep(root: Path, noise: float, shift: float) -> Path:
    """A finished sweep's output: two rules, the oracle, and two agent groups of 3 seeds."""
    rng = np.random.default_rng(int(noise * 100))
    out = root / f"noise{noise}"
    out.mkdir(parents=True)
    (out / "sweep.yaml").write_text(f"name: n{noise}\nenv_kwargs: {{noise_std: {noise}}}\ntrials: []\n")
    env = out / "eval" / "FPPI-v2"
    _per_plant(env / "baselines", {"oracle": 1.0 + rng.random(PLANTS), "rule-a": 3.0 + rng.random(PLANTS),
                                   "rule-b": 2.5 + shift + rng.random(PLANTS)})
    for label, level in (("fixed", 2.4), ("chooser", 2.0 - shift)):
        for seed in range(3):
            _per_plant(env / f"{label}-FPPI-v2-s{seed}", {"agent": level + 0.1 * rng.random(PLANTS)})
    return out


def _read(path: Path, policy: str) -> np.ndarray:
    with path.open(newline="") as file:
        return np.array([float(row["cost"]) for row in csv.DictReader(file) if row["policy"] == policy])


def test_figures_equal_a_direct_computation(tmp_path: Path) -> None:
    sweeps = [_sweep(tmp_path, 0.1, 0.0), _sweep(tmp_path, 0.01, 0.5)]
    result = compare_regimes(sweeps, "noise_std", ("chooser", "fixed", "rule-a"), resamples=300)
    assert [r["env_kwargs"]["noise_std"] for r in result["regimes"]] == [0.01, 0.1]
    for regime, directory in zip(result["regimes"], sweeps[::-1]):
        env = directory / "eval" / "FPPI-v2"
        rules = {name: _read(env / "baselines" / "per_plant.csv", name) for name in ("rule-a", "rule-b")}
        groups = {label: np.vstack([_read(env / f"{label}-FPPI-v2-s{s}" / "per_plant.csv", "agent") for s in range(3)])
                  for label in ("fixed", "chooser")}
        assert regime["best_rule"] == min(rules, key=lambda n: rules[n].mean())
        assert regime["mean_cost"]["chooser"][0] == pytest.approx(groups["chooser"].mean(), rel=1e-12)
        first, second = regime["differences"]
        assert (first["second"], second["second"]) == ("fixed", "rule-a")
        assert first["estimate"] == pytest.approx(paired_difference(groups["chooser"], groups["fixed"], resamples=300), rel=1e-12)
        assert second["estimate"] == pytest.approx(
            paired_difference(groups["chooser"], rules["rule-a"][None, :], resamples=300), rel=1e-12)
        beaten = all(paired_difference(groups["chooser"], r[None, :], resamples=300)[2] < 0 for r in rules.values())
        assert regime["agents_to_rules"]["chooser"]["beats_every_rule"] is beaten


class _Policy:
    """Agent mode on FPPI-v2: the closed-loop and open-loop steps at amplitude 3, the commit, then the
    design ``a = 0.5`` (v2 designs in a step of its own)."""

    env_id = "DeadTime/FPPI-v2"
    env_kwargs = {"experiments": "agent"}  # noqa: RUF012

    def __init__(self) -> None:
        self.calls = 0

    def predict(self, observation, deterministic=True):
        action = np.full(7, -1.0, dtype=np.float32)  # 4 experiments + commit + amplitude + design
        step = self.calls % 4
        self.calls += 1
        action[step + 1 if step < 2 else 0] = 1.0  # experiments 1 and 2 (closed-, open-loop step), commit, design
        action[-2], action[-1] = 1.0, 0.5  # amplitude 10, cut to the limit 3
        return action, None


def test_behaviour_of_a_scripted_agent(monkeypatch: pytest.MonkeyPatch) -> None:
    import agents.training.policies

    monkeypatch.setattr(agents.training.policies, "load_policy", lambda path: _Policy())
    found = behaviour([Path("a"), Path("b")], {"noise_std": 0.05}, plants=3)
    assert found["experiments_chosen"] == 2.0 and found["experiments_completed_by_commit"] == 0.0
    assert found["share_of_chosen"] == {"closed-loop-step": 0.5, "open-loop-step": 0.5}
    assert found["amplitude_quartiles"] == found["commit_amplitude_quartiles"] == [3.0, 3.0, 3.0]
    assert found["design_action_quartiles"] == [0.5, 0.5, 0.5]
    assert found["experiment_deviation"] > 0


def test_behaviour_of_a_learned_rule_on_a_plan(tmp_path: Path) -> None:
    """A learned rule (fixed mode) chooses no experiment; its plan completes the structure's two, at the
    plan's amplitudes; its design actions are its own predictions."""
    from agents.training.learned_rule_policy import load_learned_rule

    config = Path(__file__).resolve().parents[4] / "configs" / "learned_plan.yaml"
    run_dir = tmp_path / "rule"
    words = ["train", "--config", str(config), "--env", "DeadTime/FPPI-v3", "--out", str(run_dir), "training_plants=12",
             "validation_plants=4", "margins=[0.0, 0.1]", "progress_bar=false", "env_kwargs.plan=[0.3, 3]"]
    assert _run(*words)[0] == 0
    found = behaviour([run_dir], {"noise_std": 0.05}, plants=3)
    assert found["experiments_chosen"] == 0.0 and found["experiments_completed_by_commit"] == 2.0
    assert found["share_of_chosen"] == {} and found["amplitude_quartiles"] == []
    rule = load_learned_rule(run_dir)
    assert found["design_action_quartiles"][0] >= float(rule.rule.low) and found["seeds"] == 1
    assert found["plan_amplitude_quartiles"] == [[0.3, 0.3, 0.3], [3.0, 3.0, 3.0]]


class _Planner:
    """Plan mode on MSP-v3: the plan (log scale over [0.1, 10]: a = -1 is 0.1, a = 0 is 1), then the design a = 0.25."""

    env_id = "DeadTime/MSP-v3"
    env_kwargs = {"experiments": "plan"}  # noqa: RUF012

    def __init__(self) -> None:
        self.calls = 0

    def predict(self, observation, deterministic=True):
        self.calls += 1
        return (np.array([0.0, -1.0, 0.0], dtype=np.float32) if self.calls % 2 else np.array([0.0, 0.0, 0.25], dtype=np.float32)), None


def test_behaviour_of_a_plan_mode_agent(monkeypatch: pytest.MonkeyPatch) -> None:
    """The plan mode's first step is the plan (its amplitudes per plant), not a chosen experiment; the design
    action is the last component of the second step."""
    import agents.training.policies

    monkeypatch.setattr(agents.training.policies, "load_policy", lambda path: _Planner())
    found = behaviour([Path("a")], {"noise_std": 0.01}, plants=3)
    assert found["experiments_chosen"] == 0.0 and found["experiments_completed_by_commit"] == 2.0
    assert found["plan_amplitude_quartiles"] == [[pytest.approx(1.0)] * 3, [pytest.approx(0.1)] * 3]
    assert found["design_action_quartiles"] == [0.25, 0.25, 0.25]


def test_the_command_writes_its_outputs(tmp_path: Path) -> None:
    sweeps = [str(_sweep(tmp_path, noise, 0.0)) for noise in (0.01, 0.1)]
    status, out, _ = _run("regimes", *sweeps, "--x", "noise_std", "--compare", "chooser,fixed", "--out", str(tmp_path / "o"),
                          "--resamples", "100")
    assert status == 0 and out.startswith("# Regimes")
    assert json.loads((tmp_path / "o" / "regimes.json").read_text())["x"] == "noise_std"
    assert (tmp_path / "o" / "regimes.png").stat().st_size > 0


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--x", "amplitude_limit"], "env_kwargs has no 'amplitude_limit'"),
        (["--x", "noise_std", "--compare", "chooser"], "--compare must name an agent label and what to compare it with"),
        (["--x", "noise_std", "--compare", "chooser,nobody"], "no agent group, rule or procedure 'nobody'"),
    ],
    ids=["x", "compare-one", "compare-unknown"],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path: Path, extra: list[str], message: str) -> None:
    sweep = str(_sweep(tmp_path, 0.1, 0.0))
    status, _, err = _run("regimes", sweep, *extra, "--out", str(tmp_path / "o"))
    assert status == 2 and err.count("\n") == 1 and message in err, err


def test_a_directory_that_is_no_sweep_is_named(tmp_path: Path) -> None:
    status, _, err = _run("regimes", str(tmp_path), "--x", "noise_std", "--out", str(tmp_path / "o"))
    assert status == 2 and "not the output directory of a sweep" in err


def _follow_up(first: Path, tmp_path: Path) -> tuple[Path, Path]:
    """A follow-up sweep ``follow`` of ``first``'s regime whose only group is ``longer`` (``first``'s
    ``chooser`` renamed), and its environment's evaluation folder."""
    import shutil

    follow = tmp_path / "follow"
    shutil.copytree(first, follow)
    env = follow / "eval" / "FPPI-v2"
    for seed in range(3):
        shutil.rmtree(env / f"fixed-FPPI-v2-s{seed}")
        (env / f"chooser-FPPI-v2-s{seed}").rename(env / f"longer-FPPI-v2-s{seed}")
    (follow / "sweep.yaml").write_text((first / "sweep.yaml").read_text().replace("name: n0.1", "name: follow"))
    return follow, env


def test_a_group_present_in_some_regimes_only_gets_dashes_elsewhere(tmp_path: Path) -> None:
    """A follow-up group run in one regime only: its columns are '-' in the others, not an error."""
    from agents.sweeps.regimes import markdown

    first = _sweep(tmp_path, 0.1, 0.0)
    other = _sweep(tmp_path, 0.01, 0.0)
    follow, env = _follow_up(first, tmp_path)
    text = markdown(compare_regimes([other, first, follow], "noise_std", ("chooser", "fixed"), resamples=100))
    rows = [line for line in text.splitlines() if line.startswith("| noise_std=")][:2]
    assert "longer" in text.splitlines()[4] and len(rows) == 2
    assert sum(" - |" in row for row in rows) == 1


def test_sweeps_of_one_regime_are_merged(tmp_path: Path) -> None:
    """A follow-up sweep in the same regime adds its agent groups beside the first's (same rules);
    the paired difference compares groups of the two sweeps."""
    first = _sweep(tmp_path, 0.1, 0.0)
    follow, env = _follow_up(first, tmp_path)
    result = compare_regimes([first, follow], "noise_std", ("longer", "fixed"), resamples=100)
    [regime] = result["regimes"]
    assert regime["sweep"] == "n0.1 + follow" and set(regime["agents_to_rules"]) == {"fixed", "chooser", "longer"}
    (env / "baselines" / "per_plant.csv").write_text((env / "baselines" / "per_plant.csv").read_text().replace("rule-a", "rule-c"))
    with pytest.raises(ValueError, match="rules' costs differ"):
        compare_regimes([first, follow], "noise_std")


def test_groups_without_models_are_left_out_of_the_behaviour(tmp_path: Path) -> None:
    """A committed summary keeps its runs' evaluations, not their models: nothing to replay, no error."""
    sweeps = [_sweep(tmp_path, noise, 0.0) for noise in (0.01, 0.1)]
    for sweep in sweeps:
        for trial in (sweep / "eval").glob("*/*"):
            (sweep / "runs" / trial.name).mkdir(parents=True, exist_ok=True)
    result = compare_regimes(sweeps, "noise_std", (), plants=3, resamples=100)
    assert [r["behaviour"] for r in result["regimes"]] == [{}, {}]


def test_a_compare_group_of_some_regimes_is_compared_where_it_is(tmp_path: Path) -> None:
    """``--compare`` led by a follow-up group of one regime: the differences there, none elsewhere (the
    markdown's cells '-'), and the figures equal to those of that regime alone."""
    from agents.sweeps.regimes import markdown

    first = _sweep(tmp_path, 0.1, 0.0)
    other = _sweep(tmp_path, 0.01, 0.0)
    follow, _ = _follow_up(first, tmp_path)
    result = compare_regimes([other, first, follow], "noise_std", ("longer", "fixed", "rule-a"), resamples=100)
    without, within = result["regimes"]
    assert "differences" not in without
    alone = compare_regimes([first, follow], "noise_std", ("longer", "fixed", "rule-a"), resamples=100)["regimes"][0]
    assert within["differences"] == alone["differences"] and len(within["differences"]) == 2
    header, _, row_without, row_within = markdown(result).splitlines()[4:8]
    assert "longer - fixed | longer - rule-a" in header
    assert row_without.count(" - |") >= 2 and "longer" in header and row_within.count(" - |") == 0
