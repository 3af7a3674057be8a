"""Protocol v5's committed report: ``protocol_results.json`` recomputes from the committed selections and test
tables, ``results.md`` is its Markdown, and every test number of ``results.md`` is the per-plant table's."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from agents.protocol.config import load_protocol
from agents.protocol.frontier_report import frontier_markdown, frontiers_figure
from agents.protocol.frontier_run import frontier_results, read_table

REPO = Path(__file__).resolve().parents[4]
V5 = REPO / "results" / "protocol_v5"
PROTOCOL = REPO / "configs" / "protocols" / "v5.yaml"

pytestmark = pytest.mark.skipif(not (V5 / "protocol_results.json").exists(), reason="protocol v5 has no regime tested")


def _committed() -> dict:
    return json.loads((V5 / "protocol_results.json").read_text())


def test_v5s_results_recompute_from_its_selections_and_test_tables(tmp_path):
    copy = tmp_path / "protocol_v5"
    shutil.copytree(V5, copy, ignore=shutil.ignore_patterns("*.png", "*.md", "protocol_results.json"))
    found, committed = json.loads(json.dumps(frontier_results(load_protocol(PROTOCOL), copy))), _committed()
    assert Path(found.pop("protocol")) == PROTOCOL and committed.pop("protocol") == "configs/protocols/v5.yaml"
    assert found == committed


def test_v5s_results_md_is_the_markdown_of_its_results():
    results = _committed()
    assert (V5 / "results.md").read_text() == frontier_markdown(results, len(load_protocol(PROTOCOL).regimes))
    assert results["protocol_sha256"] == load_protocol(PROTOCOL).sha256 and results["code"]["sha256"]


def test_v5s_test_costs_and_risks_are_the_per_plant_tables():
    """Each tested policy's mean cost and risk, read again from ``test_per_plant.csv.gz`` with numpy alone."""
    for name, regime in _committed()["regimes"].items():
        table = read_table(V5 / name / "test_per_plant.csv.gz")
        for label, policy in regime["test"].items():
            costs, violated = table[label]
            assert policy["mean_cost"] == pytest.approx(float(np.mean(costs)), rel=1e-12)
            assert policy["risk"] == pytest.approx(float(np.mean(violated)), rel=1e-12)
            assert costs.shape == (policy["seeds"], regime["test_plants"])


def test_the_frontiers_figure_has_one_panel_per_regime(tmp_path):
    from PIL import Image

    path = frontiers_figure(_committed(), tmp_path / "f.png")
    width, height = Image.open(path).size
    assert width > 800 and height > 300


def test_the_answer_table_has_one_row_per_regime_at_1_percent_or_the_least_level_a_rule_reaches():
    from agents.protocol.frontier_report import answer_table

    results = _committed()
    rows = answer_table(results)[2:]
    assert len(rows) == len(results["regimes"]) and all(row.count("|") == 8 for row in rows)
    for row, (name, regime) in zip(rows, results["regimes"].items()):
        reached = [level for level, best in regime["best"].items() if best["rule"] is not None and best["learned"] is not None]
        later = [level for level in reached if float(level.rstrip("%")) >= 1.0]
        assert row.startswith(f"| {name} | {later[0] if later else '-'}")


def test_a_learned_family_has_one_legend_name_and_one_colour_in_every_panel():
    from agents.protocol.frontier_report import _colour, _legend_name

    assert _legend_name("learned-pid@0.01") == _legend_name("learned-msp@0.01") == "learned-<s>@0.01"
    assert _legend_name("learned-rule") == "learned-rule" and _legend_name("sac-lagrangian") == "sac-lagrangian"
    assert _colour("learned-fppi@0.005") == _colour("learned-pi@0.005") != _colour("learned-pi@0.05")
    names = ["learned-rule", "selector", "sac", "ppo", "sac-lagrangian", "learned-pid@0.005", "learned-pid@0.01",
             "learned-pid@0.02", "learned-pid@0.05"]
    assert len({_colour(name) for name in names}) == len(names)
