"""A frontier protocol: its schema, its choices on validation, its Holm family, and the tiny one's run
serially, by ``--address`` on a Ray cluster and interrupted then resumed, each writing the same tables."""

from __future__ import annotations

import dataclasses
import json
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from ray_cluster import command_running, driver_environment
from tiny_protocol import FRONTIER, write_rule, write_tiny_frontier_protocol

from agents.protocol.config import load_protocol
from agents.protocol.frontier_run import FamilySpec, comparisons_of, frontier_choices

REGIMES = ("pid-quiet", "pid-noisy")
TABLES = ("pid-quiet/test_per_plant.csv.gz", "pid-noisy/test_per_plant.csv.gz", "work/pid-quiet/validation_per_plant.csv.gz",
          "work/pid-noisy/validation_per_plant.csv.gz")


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "p.yaml"
    path.write_text(text.format(rule=write_rule(tmp_path, 20)))
    return path


def test_the_tiny_frontier_protocol_loads_with_its_families_and_the_earlier_protocols_still_load(tmp_path):
    protocol = load_protocol(_write(tmp_path, FRONTIER))
    assert protocol.frontier.knobs == (-0.5, 0.0, 0.5) and protocol.frontier.rules == ("simc-pi", "gorez-klan-mu-2")
    assert protocol.regimes[1].rules == ("amigo-pid",) and [l.label for l in protocol.regimes[0].learners()] == ["tiny-fixed"]
    assert protocol.regimes[0].pretrained == ("learned-pid@0.05",) and protocol.regimes[1].pretrained == ()
    for version in ("v1", "v2", "v3", "v4"):
        assert load_protocol(Path(f"configs/protocols/{version}.yaml")).frontier is None


@pytest.mark.parametrize("edit, message", [
    (("knobs: [-0.5, 0, 0.5]", "knobs: [-0.5, 0.5]"), "hold 0"),
    (("knobs: [-0.5, 0, 0.5]", "knobs: [0, -0.5]"), "increasing"),
    (("knobs: [-0.5, 0, 0.5]", "knobs: [0, 9]"), "from -5 to 5"),
    (("0.05, 0.5]", "0.05, 1.5]"), r"risk_levels\[4\]"),
    (("min_seeds: 2", "min_seeds: 10"), "min_seeds asks for 10"),
    (("rules: [simc-pi,", "rules: [oracle,"), "is not a rule"),
    (("label: tiny-fixed, config", "label: simc-pi, config"), "must not name a rule"),
    (("frontier:", "selection: []\nfrontier:"), "selection"),
    (("learned-pid@0.05]", "learned-fppi@0.05]"), r"pretrained\[0\]: 'learned-fppi@0.05' designs the FPPI structure"),
    (("learned-pid@0.05]", "learned-pid@0.7]"), r"pretrained\[0\].*in \(0, 0.5\)"),
    (("learned-pid@0.05]", "learned-pid@0.05, learned-pid@0.05]"), "repeats a name"),
])
def test_a_bad_frontier_protocol_is_refused_naming_what_is_wrong(tmp_path, edit, message):
    with pytest.raises(ValueError, match=message):
        load_protocol(_write(tmp_path, FRONTIER.replace(*edit, 1)))


def _table(costs: dict[str, tuple[list[float], list[float]]]) -> dict:
    """Families at knobs -1, 0, 1 of one seed each: ``name -> (mean costs, risks)`` over the knobs, on 200 plants."""
    table = {}
    for name, (means, risks) in costs.items():
        for knob, mean, risk in zip((-1.0, 0.0, 1.0), means, risks):
            violated = np.zeros((2, 200), dtype=bool)
            violated[:, : int(round(risk * 200))] = True
            table[f"{name}@{knob!r}"] = (np.full((2, 200), mean), violated)
    table["oracle"] = (np.full((1, 200), 1.0), np.zeros((1, 200), dtype=bool))
    return table


def test_the_choices_are_the_least_cost_knob_within_each_risk_level_and_cannot_reach_is_recorded(tmp_path):
    protocol = load_protocol(_write(tmp_path, FRONTIER.replace("knobs: [-0.5, 0, 0.5]", "knobs: [-1, 0, 1]")))
    specs = [FamilySpec("r1", "rule", ()), FamilySpec("r2", "rule", ()), FamilySpec("l1", "learned", ())]
    table = _table({"r1": ([3.0, 4.0, 5.0], [0.03, 0.015, 0.0]), "r2": ([2.0, 3.0, 6.0], [0.2, 0.1, 0.06]),
                    "l1": ([2.5, 3.5, 4.5], [0.008, 0.004, 0.0])})
    found = frontier_choices(protocol, specs, table)
    assert found["chosen"]["r1"] == {"0.5%": 1.0, "1%": 1.0, "2%": 0.0, "5%": -1.0, "50%": -1.0}
    assert found["chosen"]["r2"]["5%"] is None and found["chosen"]["r2"]["50%"] == -1.0
    assert found["cannot_reach"]["5%"] == ["r2"]
    assert found["best"]["2%"]["rule"]["family"] == "r1" and found["best"]["2%"]["learned"]["knob"] == -1.0
    assert found["best"]["50%"]["rule"]["family"] == "r2"
    assert found["shipped_rule"]["family"] == "r2" and found["shipped_rule"]["risk"] == 0.1  # least cost at s = 0
    assert found["learned_at_shipped_rule_risk"]["knob"] == -1.0
    assert found["frontiers"]["r1"]["risk_union"] == [0.03, 0.015, 0.0]
    pairs = [(c["first"]["family"], c["first"]["knob"], c["second"]["family"], c["second"]["knob"]) for c in comparisons_of(found)]
    assert pairs == [("l1", 0.0, "r1", 1.0), ("l1", -1.0, "r1", 1.0), ("l1", -1.0, "r1", 0.0), ("l1", -1.0, "r1", -1.0),
                     ("l1", -1.0, "r2", -1.0), ("l1", -1.0, "r2", 0.0)]  # per level, then at the shipped rule's risk


@pytest.fixture(scope="module")
def tiny_frontier_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The tiny frontier protocol run in this process, one task after another: its path and its run folder."""
    from agents.protocol.run import run_protocol

    folder = tmp_path_factory.mktemp("frontier")
    path = write_tiny_frontier_protocol(folder)
    assert run_protocol(load_protocol(path), folder / "out") == list(REGIMES)
    return path, folder / "out"


def _command(protocol: Path, out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "agents.cli", "protocol", "run", str(protocol), "--out", str(out), *extra]


def _assert_same_run(expected: Path, found: Path) -> None:
    for name in TABLES:
        assert (found / name).read_bytes() == (expected / name).read_bytes(), name
    for regime in REGIMES:
        for name in ("selection.json", "summary.json"):
            first, second = (json.loads((folder / regime / name).read_text()) for folder in (expected, found))
            for record in (first, second):
                record.pop("commit", None), record.pop("code_sha256", None)
            assert first == second, (regime, name)
    assert (json.loads((found / "protocol_results.json").read_text())["regimes"]
            == json.loads((expected / "protocol_results.json").read_text())["regimes"])


@pytest.mark.slow
def test_the_tiny_frontier_protocol_writes_its_results_with_holm_once_per_pair(tiny_frontier_run):
    """The results recomputed by the report from the committed files are the run's; each pair once under Holm."""
    from agents.protocol.frontier_run import frontier_results

    path, out = tiny_frontier_run
    results = json.loads((out / "protocol_results.json").read_text())
    assert json.loads(json.dumps(frontier_results(load_protocol(path), out))) == results
    assert results["interval_method"].startswith("crossed random effects") and results["code"]["sha256"]
    holm = [c for regime in results["regimes"].values() for c in regime["matched"] if "holm_p_value" in c]
    assert len(holm) == results["comparisons_in_holm_family"]
    assert len({(c["first_policy"], c["second_policy"], r) for r, regime in results["regimes"].items()
                for c in regime["matched"]}) == len(holm)
    for regime in results["regimes"].values():
        assert set(regime["frontiers"]) >= {"tiny-fixed"} and regime["test"]["oracle"]["seeds"] == 1
        assert len(regime["frontiers"]["tiny-fixed"]["risk_per_seed"][0]) == 2
    shipped = results["regimes"]["pid-quiet"]["frontiers"]["learned-pid@0.05"]  # the shipped learner: one model
    assert shipped["kind"] == "learned" and all(len(row) == 1 for row in shipped["risk_per_seed"])
    from agents.protocol.frontier_report import write_frontier_report

    written = write_frontier_report(results, out, 2)
    text = written[0].read_text()
    assert [path.name for path in written] == ["results.md", "frontiers.png"] and "2 of 2 regimes tested" in text
    for regime in results["regimes"].values():
        for c in regime["matched"]:
            d = c["difference"]
            assert f"{d['estimate']:+.3g} [{d['low']:.3g}, {d['high']:.3g}]" in text


@pytest.mark.slow
def test_the_tiny_frontier_protocol_by_address_on_a_ray_cluster_writes_the_serial_tables(
        tiny_frontier_run, ray_start_cluster, tmp_path):
    protocol, serial = tiny_frontier_run
    address, environment = ray_start_cluster
    out = tmp_path / "on-cluster"
    done = subprocess.run(_command(protocol, out, "--address", address, "--chunk-plants", "2"), cwd=tmp_path,
                          env=environment, capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "validation simc-pi@[-0.5, 0.0, 0.5] plants 2-3 (pid-quiet) done" in done.stderr  # chunks of two plants, every knob
    _assert_same_run(serial, out)


@pytest.mark.slow
def test_the_tiny_frontier_protocol_interrupted_resumes_to_the_serial_tables(tiny_frontier_run, tmp_path):
    protocol, serial = tiny_frontier_run
    out = tmp_path / "out"
    with command_running(_command(protocol, out), tmp_path) as first:
        for line in first.stderr:
            if "validation" in line and "done (3 of" in line:  # three frontier tasks done, the fourth started
                break
        first.send_signal(signal.SIGTERM)
        rest = first.communicate(timeout=300)[1]
    assert first.returncode == 143, rest[-2000:]
    assert not (out / "pid-quiet" / "selection.json").exists()
    again = subprocess.run(_command(protocol, out, "--resume"), cwd=tmp_path, env=driver_environment(), capture_output=True,
                           text=True, timeout=1800)
    assert again.returncode == 0, again.stderr[-3000:]
    _assert_same_run(serial, out)


def test_v5_loads_on_fresh_streams_and_is_registered():
    """Eight regimes, ten seeds, the declared risk levels; its entropies and episode seeds used by no other protocol;
    its test seed registered with the file's sha256.  It names configs/v5/*.yaml, the stable-baselines3 candidates."""
    import re

    from agents.protocol.streams import read_registry

    path = Path("configs/protocols/v5.yaml")
    if not Path("configs/v5/sac.yaml").is_file():
        pytest.skip("configs/v5/ (the stable-baselines3 candidates' configs) is not in this tree")
    protocol = load_protocol(path)
    assert len(protocol.regimes) == 8 and len(protocol.seeds) == 10
    assert protocol.frontier.risk_levels == (0.005, 0.01, 0.02, 0.05) and 0.0 in protocol.frontier.knobs
    assert all({"sac", "ppo", "learned-rule", "selector"} <= {l.label for l in r.learners()} for r in protocol.regimes)
    assert all("sac-lagrangian" in {l.label for l in r.learners()} for r in protocol.regimes if r.name.endswith("fixed-default"))
    assert all(len(r.pretrained) == 4 for r in protocol.regimes)
    assert {"entropy": protocol.test.entropy, "sha256": protocol.sha256}.items() <= next(
        entry for entry in read_registry() if entry["entropy"] == protocol.test.entropy).items()
    others = "".join(p.read_text() for p in Path("configs/protocols").glob("v[1-4].yaml"))
    entropies = {int(e) for e in re.findall(r"entropy: (\d+)", others)}
    assert not {protocol.validation.entropy, protocol.test.entropy} & entropies
    assert {protocol.validation.episode_seed, protocol.test.episode_seed}.isdisjoint({50000000, 60000000})


def test_the_regime_summary_risks_and_gap_closed_recompute_independently():
    """Risk per seed averaged, pooled Clopper-Pearson from scipy's binomial test, gap closed from the means."""
    from scipy import stats

    from agents.protocol.frontier_run import regime_summary

    rng = np.random.default_rng(1)
    learner = (rng.gamma(3.0, 1.0, size=(4, 50)), rng.random((4, 50)) < 0.1)
    rule = (rng.gamma(4.0, 1.0, size=(1, 50)), rng.random((1, 50)) < 0.2)
    oracle = (np.full((1, 50), 0.5), np.zeros((1, 50), dtype=bool))
    point = {"family": "l", "knob": 0.5, "kind": "learned", "mean_cost": 0.0, "risk": 0.0}
    second = {**point, "family": "r", "knob": 0.0, "kind": "rule"}
    selection = {"regime": "x", "env": "e", "env_kwargs": {}, "best": {"1%": {"learned": point, "rule": second}},
                 "shipped_rule": second, "learned_at_shipped_rule_risk": None}
    found = regime_summary(selection, {"l@0.5": learner, "r@0.0": rule, "oracle": oracle})
    risk = found["policies"]["l@0.5"]
    assert risk["risk"] == pytest.approx(np.mean([row.mean() for row in learner[1]]))
    pooled = stats.binomtest(int(learner[1].sum()), learner[1].size).proportion_ci(0.95, method="exact")
    assert risk["risk_interval"] == pytest.approx([pooled.low, pooled.high])
    [comparison] = found["comparisons"]
    gap = (rule[0].mean() - learner[0].mean()) / (rule[0].mean() - 0.5)
    assert comparison["gap_closed"]["estimate"] == pytest.approx(gap)
    low, high = comparison["gap_closed"]["interval"]
    assert low < gap < high
    assert comparison["difference"]["estimate"] == pytest.approx(learner[0].mean() - rule[0].mean())


def test_a_rule_familys_knobs_on_one_identification_write_the_tables_of_their_own_tasks(tmp_path):
    """:class:`Knobs` (one reset per plant for every knob) writes each member's table byte for byte as that member's
    own task (its own reset per plant) writes it, on a noisy priced regime; a finished batch is not rerun."""
    from agents.protocol.members import Knobs, Member, batched, score_knobs, score_member
    from envs.systems.plant_sets import plant_set

    kwargs = {"noise_std": 0.1, "weights": {"production": 0.05}}
    plants = tuple(plant.to_dict() for plant in plant_set("fopdt", "validation", 3))

    def members(rule: str, folder: str) -> list[Member]:
        return [Member("r", "validation", rule, "rule", rule, knob, "", 0, "DeadTime/PID-v3", kwargs, plants, 70000000,
                       str(tmp_path / folder / rule / f"k{knob!r}")) for knob in (-0.5, 0.0, 1.0)]

    for rule in ("amigo-pid", "gorez-klan-mu-2"):
        alone, together = members(rule, "alone"), members(rule, "together")
        for task in alone:
            score_member(task)
        [batch] = batched(together)
        assert isinstance(batch, Knobs) and batch.members == tuple(together)
        score_knobs(batch)
        for a, b in zip(alone, together):
            assert (Path(a.directory) / "per_plant.csv").read_bytes() == (Path(b.directory) / "per_plant.csv").read_bytes()
        mtime = (Path(together[0].directory) / "per_plant.csv").stat().st_mtime_ns
        score_knobs(batch)
        assert (Path(together[0].directory) / "per_plant.csv").stat().st_mtime_ns == mtime
    oracle = Member("r", "validation", "oracle", "oracle", "oracle", 0.0, "", 0, "DeadTime/PID-v3", kwargs, plants, 70000000, "x")
    assert batched([oracle, *members("simc-pi", "b")]) [0] is oracle and len(batched([oracle, *members("simc-pi", "b")])) == 2
    other = [dataclasses.replace(task, regime="another") for task in members("simc-pi", "c")]
    assert [len(batch.members) for batch in batched([*members("simc-pi", "b"), *other])] == [3, 3]  # never across regimes


def test_one_models_comparison_is_the_paired_t_over_the_plants():
    """A shipped learner is one model: its interval is scipy's one-sample t on the paired differences."""
    from scipy import stats

    from agents.frontier.statistics import seeds_or_plants_interval, seeds_or_plants_p_value

    d = np.random.default_rng(3).normal(0.2, 1.0, size=(1, 80))
    found = seeds_or_plants_interval(d)
    test = stats.ttest_1samp(d[0], 0.0)
    low, high = test.confidence_interval(0.95)
    assert (found.low, found.high) == pytest.approx((low, high)) and found.method.startswith("paired t")
    assert seeds_or_plants_p_value(d) == pytest.approx(test.pvalue)
    assert seeds_or_plants_interval(np.vstack([d, d + 0.1])).method.startswith("crossed")


def _learned_knobs_match(tmp_path: Path, member: str, env_kwargs: dict, plants: int = 3) -> None:
    """A learned family's :class:`Knobs` (one reset per plant, each knob's episode on its own copy) writes each
    member's table byte for byte as that member's own task writes it."""
    from agents.protocol.members import Knobs, Member, score_knobs, score_member
    from envs.systems.plant_sets import plant_set

    dicts = tuple(plant.to_dict() for plant in plant_set("fopdt", "validation", plants))

    def members(folder: str) -> list[Member]:
        return [Member("r", "validation", "family", "learned", member, knob, "0", 0, "DeadTime/PID-v3", env_kwargs, dicts,
                       70000000, str(tmp_path / folder / f"k{knob!r}")) for knob in (-1.0, 0.0, 1.5)]

    alone, together = members("alone"), members("together")
    for task in alone:
        score_member(task)
    score_knobs(Knobs(tuple(together)))
    for a, b in zip(alone, together):
        assert (Path(a.directory) / "per_plant.csv").read_bytes() == (Path(b.directory) / "per_plant.csv").read_bytes()


def test_a_shipped_learners_knobs_on_one_reset_write_the_tables_of_their_own_tasks(tmp_path):
    _learned_knobs_match(tmp_path, "learned-pid@0.05", {"noise_std": 0.1, "weights": {"production": 0.05}})


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["selector", "sac-plan"])
def test_a_selectors_and_a_plan_mode_agents_knobs_on_one_reset_write_the_tables_of_their_own_tasks(tmp_path, kind):
    """A selector (its threshold the knob) and an agent that plans its experiments (the plan's step shared, the
    design's stepped per knob), each trained on a few plants."""
    fit = tmp_path / "fit"
    if kind == "selector":
        overrides = ["training_plants=60", "validation_plants=40",
                     'learned_overrides=["training_plants=30", "validation_plants=10", "margins=[0.0, 0.2]"]']
        config, env_kwargs = "configs/selector.yaml", {}
    else:
        overrides = ["env_kwargs.experiments=plan", "env_kwargs.noise_std=0.1", "total_timesteps=300",
                     "hyperparameters.learning_starts=100", "eval_freq=300", "n_eval_episodes=5"]
        config, env_kwargs = "configs/v5/sac.yaml", {"noise_std": 0.1}
    done = subprocess.run([sys.executable, "-m", "agents.cli", "train", "--config", config, "--env", "DeadTime/PID-v3",
                           "--out", str(fit), *overrides], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    _learned_knobs_match(tmp_path, str(fit), env_kwargs)


@pytest.mark.slow
def test_the_budget_counts_every_task_of_the_run_by_part_and_kind(tiny_frontier_run):
    """Every fit and every (family, seed, chunk) task recorded its time; the episodes are the stream's plants times
    the members: pid-quiet's validation has 2 rule families, 1 learner of 2 seeds and 1 shipped learner at 3 knobs."""
    from agents.protocol.budget import budget, budget_summary, budget_table

    path, out = tiny_frontier_run
    found = budget(load_protocol(path), out)["regimes"]["pid-quiet"]
    assert found["fits"]["tiny-fixed"]["tasks"] == 2 and found["fits"]["tiny-fixed"]["cpu_seconds"] > 0
    episodes = {kind: entry["episodes"] for kind, entry in found["validation"].items()}
    assert episodes == {"rules": 2 * 3 * 4, "learners": 2 * 3 * 4, "shipped": 3 * 4, "oracle": 4}
    assert set(found["test"]) >= {"oracle"} and found["test"]["oracle"]["episodes"] == 5
    table = budget_table(budget(load_protocol(path), out))
    assert "| pid-quiet | validation | shipped | 1 | 12 |" in table and table.splitlines()[-1].startswith("| all |")
    # the summary by part: its regimes' rows add up to the detail's total
    summary = budget_summary(budget(load_protocol(path), out)).splitlines()
    assert summary[0].startswith("| regime | labels and learned-rule fits |") and summary[-1].startswith("| all |")
    assert summary[-1].split(" | ")[-2] == table.splitlines()[-1].split(" | ")[-2]


def test_the_budgets_summary_puts_each_fit_in_its_part_by_its_algorithm():
    from agents.protocol.budget import budget_summary

    def entry(hours, algorithm=None):
        return {"cpu_seconds": 3600 * hours, "wall_seconds": 0.0, "episodes": 0, "tasks": 1,
                **({"algorithm": algorithm} if algorithm else {})}

    found = {"regimes": {
        "a": {"fits": {"learned-rule": entry(1.0, "learned-rule"), "selector": entry(0.5, "selector"),
                       "sac": entry(0.25, "SAC"), "ppo": entry(0.5, "PPO")},
              "validation": {"rules": entry(2.0), "learners": entry(1.0)}, "test": {"oracle": entry(0.25)}},
        "b": {"fits": {}, "validation": {}, "test": {}}}}
    lines = budget_summary(found, workers=2).splitlines()
    assert lines[2] == "| a | 1.00 | 0.50 | 0.75 | 3.00 | 0.25 | 5.50 | 2.75 |"
    assert lines[3] == "| all | 1.00 | 0.50 | 0.75 | 3.00 | 0.25 | 5.50 | 2.75 |" and len(lines) == 4  # b has no work yet


@pytest.mark.parametrize("extra, message", [
    (["configs/protocols/v1.yaml", "--out", "x"], "not a frontier protocol"),
    (["PROTOCOL", "--out", "nowhere"], "no run of"),
    (["PROTOCOL", "--out", "x", "--workers", "0"], "--workers must be at least 1"),
])
def test_a_bad_budget_request_is_one_line(tmp_path, extra, message):
    from in_process import error_line

    protocol = write_tiny_frontier_protocol(tmp_path)
    (tmp_path / "x" / "work").mkdir(parents=True)
    args = [str(protocol) if a == "PROTOCOL" else str(tmp_path / a) if a in ("x", "nowhere") else a for a in extra]
    assert message in error_line("protocol", "budget", *args)
