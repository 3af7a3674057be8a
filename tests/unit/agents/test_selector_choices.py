"""The selector-choices study: shares, violations and judgement per dead-time band, from a run's validation rows."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from types import SimpleNamespace

import pytest

from agents.protocol.streams import plant_stream
from agents.studies.selector_choices import BANDS, markdown, regime_choices

ENTROPY = 4242
PLANTS = 12


def _write(run: Path, rows: list[dict]) -> None:
    (run / "r").mkdir(parents=True)
    (run / "r" / "selection.json").write_text(json.dumps({"env": "DeadTime/PID-v3", "family": "stable", "validation_plants": PLANTS,
                                                          "chosen": {"best-rule": "rule-a"}}))
    folder = run / "work" / "r" / "validation"
    folder.mkdir(parents=True)
    with (folder / "per_plant.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, ["index", "subset", "policy", "cost", "feasible", "choice"])
        writer.writeheader()
        writer.writerows(rows)


def test_the_bands_count_choices_violations_and_judgement(tmp_path: Path) -> None:
    # rule-a violates on even plants; the selector leaves it there in seed s0 only, and keeps it elsewhere
    rows = []
    for k in range(PLANTS):
        rows.append({"index": k, "subset": "test", "policy": "rule-a", "cost": 21.5 if k % 2 == 0 else 3.0,
                     "feasible": k % 2 != 0, "choice": ""})
        for seed in ("s0", "s1"):
            leave = k % 2 == 0 and seed == "s0"
            rows.append({"index": k, "subset": "test", "policy": f"fixed.selector.{seed}", "cost": 2.0 if leave else (21.5 if k % 2 == 0 else 3.0),
                         "feasible": leave or k % 2 != 0, "choice": "learned" if leave else "rule-a"})
        # a plan-mode selector of the same regime runs other experiments: not read
        rows.append({"index": k, "subset": "test", "policy": "plan.selector-plan.s0", "cost": 1.0,
                     "feasible": False, "choice": "rule-b"})
    _write(tmp_path, rows)
    found = regime_choices(SimpleNamespace(validation=SimpleNamespace(entropy=ENTROPY)), tmp_path, "r")
    fractions = [p.dead_time / p.residence_time for p in plant_stream("stable", ENTROPY, PLANTS)]
    assert found["seeds"] == 2 and found["candidates"] == ["rule-a", "learned"]
    assert sum(band["plants"] for band in found["bands"]) == PLANTS
    assert [band["plants"] for band in found["bands"]] == [sum(1 for f in fractions if low <= f < high or (high == 1.0 and f == 1.0))
                                                          for low, high in zip(BANDS[:-1], BANDS[1:])]
    total_left = [band["overridden_where_best_rule_violates"] for band in found["bands"]
                  if band["plants"] and band["overridden_where_best_rule_violates"] is not None]
    assert all(value == pytest.approx(0.5) for value in total_left)  # one seed of two leaves it
    assert all(band["kept_where_best_rule_is_safe"] in (None, 1.0) for band in found["bands"] if band["plants"])
    assert "| learned" not in markdown([found]) and "`learned` chosen" in markdown([found])


def test_a_run_without_its_validation_rows_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "r").mkdir()
    (tmp_path / "r" / "selection.json").write_text("{}")
    with pytest.raises(ValueError, match="per_plant.csv is missing: run the protocol's regime first"):
        regime_choices(SimpleNamespace(validation=SimpleNamespace(entropy=ENTROPY)), tmp_path, "r")
