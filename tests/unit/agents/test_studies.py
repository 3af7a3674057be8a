"""``deadtime study NAME``: every study has its command line and a test that runs it small and checks its
output (here, or beside the code it studies); the command prints what its function returns."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from in_process import run_deadtime as run

from agents.commands.study import STUDIES

REPO = Path(__file__).resolve().parents[3]

RUN_SMALL = {
    # module of agents/studies -> the test that runs it small and checks its table
    "commit": "tests/unit/agents/sweeps/test_sweep.py::test_a_committed_sweep_is_compressed_and_recomputes_its_summary",
    "continuation": "tests/unit/agents/test_headroom.py::test_the_learned_continuation_is_scored_by_the_expected_cost_of_its_choice",
    "headroom": "tests/unit/agents/test_studies.py::test_the_headroom_study_runs_small_on_the_protocols_regimes",
    "learned_headroom": "tests/unit/agents/test_headroom.py::test_the_learners_share_of_the_headroom_and_their_violating_plants",
    "numba_dispatch": "tests/unit/agents/test_studies.py::test_the_numba_dispatch_study_prints_a_line_per_kernel",
    "selector_choices": "tests/unit/agents/test_selector_choices.py::test_the_bands_count_choices_violations_and_judgement",
    "sequential_replay": "tests/unit/agents/training/test_sequential.py::test_a_trained_sequential_agent_loads_and_plays_only_allowed_actions",
    "transfer": "tests/unit/agents/test_transfer.py::test_the_study_runs_a_condition_with_a_rule_only_group",
    "violation_cost_plot": "tests/unit/agents/test_studies.py::test_the_violation_cost_plot_writes_its_figure",
}


@pytest.mark.parametrize("name", list(STUDIES))
def test_every_study_has_its_help(name: str) -> None:
    status, out, _ = run("study", name, "--help")
    assert status == 0 and out.startswith(f"usage: deadtime study {name}")


def test_an_unknown_study_is_one_line() -> None:
    status, _, err = run("study", "nothing")
    assert status == 2 and len(err.strip().splitlines()) == 1 and "invalid choice: 'nothing'" in err


def test_every_study_module_has_a_test_that_runs_it() -> None:
    """Each module of agents/studies is named here with a test that exists and imports or runs it."""
    modules = {p.stem for p in (REPO / "agents" / "studies").glob("*.py")} - {"__init__"}
    assert modules == set(RUN_SMALL)
    for module, test in RUN_SMALL.items():
        path, name = test.split("::")
        text = (REPO / path).read_text()
        assert f"def {name}(" in text, test
    assert {name.replace("-", "_") for name in STUDIES} <= modules


def test_the_violation_cost_plot_writes_its_figure(tmp_path: Path) -> None:
    status, out, _ = run("study", "violation-cost-plot", str(tmp_path / "figure.png"))
    assert status == 0 and out == "" and (tmp_path / "figure.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_numba_dispatch_study_prints_a_line_per_kernel() -> None:
    from numba.core.registry import CPUDispatcher

    from agents.studies.numba_dispatch import _kernels

    status, out, _ = run("study", "numba-dispatch", "--slots", "2", "--rounds", "1", "--calls", "3")
    lines = out.strip().splitlines()
    assert status == 0 and len(lines) >= 2 and re.fullmatch(r"numba dispatch per episode: \d+\.\d us", lines[-1])
    assert all(re.search(r"calls/episode +\d+\.\d\d  arguments +\d+  dispatch +\d+\.\d\d us$", line) for line in lines[:-1])
    assert all(isinstance(function, CPUDispatcher) for _, _, function in _kernels())  # every kernel put back


def test_the_numba_dispatch_study_refuses_zero_calls_in_one_line() -> None:
    status, out, err = run("study", "numba-dispatch", "--calls", "0")
    assert status == 2 and out == "" and len(err.strip().splitlines()) == 1 and "--calls" in err


@pytest.mark.parametrize("argument", ["--slots", "--rounds", "--calls"])
def test_the_numba_dispatch_study_refuses_unbounded_work_in_one_line(argument: str) -> None:
    status, out, err = run("study", "numba-dispatch", argument, "1000000000000")
    assert status == 2 and out == "" and len(err.strip().splitlines()) == 1 and argument in err


@pytest.mark.slow
def test_the_headroom_study_runs_small_on_the_protocols_regimes(tmp_path: Path) -> None:
    """Two validation plants, two noise draws: one row per plan regime of protocol v1, the headroom the
    best single plan's cost less the adaptive oracle's, and the JSON and the table written beside."""
    from agents.protocol.config import load_protocol

    status, out, _ = run("study", "headroom", "--plants", "2", "--replicates", "2", "--out", str(tmp_path))
    regimes = [r.name for r in load_protocol(REPO / "configs" / "protocols" / "v1.yaml").regimes if r.plan]
    rows = [line for line in out.splitlines() if line.startswith("| ") and not line.startswith("| regime")]
    assert status == 0 and [row.split(" | ")[0][2:] for row in rows] == regimes
    record = json.loads((tmp_path / "headroom.json").read_text())
    assert record["plants"] == 2 and [row["regime"] for row in record["rows"]] == regimes
    for row in record["rows"]:
        assert row["plants"] == 2 and row["headroom"] == pytest.approx(row["best_plan_cost"] - row["adaptive_cost"], abs=1e-12)
    assert (tmp_path / "headroom.md").read_text() + "\n" == out
