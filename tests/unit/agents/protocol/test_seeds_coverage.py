"""The coverage check of the seeds-random interval on a per-seed table: populations read as the protocol writes
them, and the coverage on a table of the crossed model near the nominal level."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from agents.frontier.statistics import simulate_crossed
from in_process import error_line, run_deadtime

from agents.protocol.seeds_coverage import populations, seeds_coverage


def _table(path: Path, seeds: int = 10, plants: int = 300, seed: int = 0) -> np.ndarray:
    """A frontier protocol's test table: a learner of ``seeds`` seeds, a rule and the oracle; the differences."""
    rng = np.random.default_rng(seed)
    rule = rng.gamma(4.0, 1.0, size=plants)
    d = simulate_crossed(rng, seeds, plants, 0.2, 0.3, 1.0, 0.5)
    learners = [f"learner@0.5#{i}" for i in range(seeds)]
    names = ["rule@0.0", *learners, "oracle"]
    lines = [",".join(["plant", *(f"cost:{n}" for n in names), *(f"feasible:{n}" for n in names)])]
    lines += [",".join([str(j), repr(float(rule[j])), *(repr(float(rule[j] + d[i, j])) for i in range(seeds)), "0.5",
                        *("1" for _ in names)]) for j in range(plants)]
    path.write_bytes(gzip.compress(("\n".join(lines) + "\n").encode()))
    return d


def test_the_population_is_the_learner_minus_rule_matrix_of_the_table(tmp_path):
    """In a frontier protocol's table (a column per policy and seed); an earlier protocol's is read by the committed
    check (test below)."""
    d = _table(tmp_path / "t.csv.gz")
    [found] = populations(tmp_path / "t.csv.gz")
    assert (found["learner"], found["rule"]) == ("learner@0.5", "rule@0.0")
    assert np.allclose(found["differences"], d, atol=1e-12)


def test_on_the_crossed_model_the_coverage_is_near_nominal_as_the_simulation_of_the_model_finds(tmp_path):
    """Resampling one table of the crossed normal model: within four Monte Carlo errors of 0.95 (200 replicates),
    as :func:`agents.frontier.statistics.coverage` finds by simulating the model itself."""
    from agents.frontier.statistics import coverage, crossed_variance

    _table(tmp_path / "t.csv.gz")
    result = seeds_coverage([tmp_path / "t.csv.gz"], replicates=200)
    error = 4 * np.sqrt(0.95 * 0.05 / 200)
    assert abs(result["smallest_coverage"] - 0.95) <= error
    model = coverage(crossed_variance, replicates=200, plants=300)
    assert abs(model.covered - 0.95) <= error


def test_the_command_writes_its_json_and_refuses_a_missing_table_in_one_line(tmp_path):
    _table(tmp_path / "t.csv.gz", plants=50)
    status, _, _ = run_deadtime("protocol", "seeds-coverage", str(tmp_path / "t.csv.gz"), "--replicates", "20", "--seeds", "20",
                                "--out", str(tmp_path / "c.json"))
    assert status == 0
    written = json.loads((tmp_path / "c.json").read_text())
    assert written["populations"][0]["seeds_resampled"] == 20 and written["method"].startswith("crossed random effects")
    assert "missing.csv.gz" in error_line("protocol", "seeds-coverage", str(tmp_path / "missing.csv.gz"))


def test_the_committed_seeds_random_coverage_is_the_one_docs_protocol_quotes():
    committed = json.loads(Path("results/protocol_coverage/seeds_random.json").read_text())
    docs = Path("docs/protocol.md").read_text()
    assert committed["populations_checked"] == 47 and committed["replicates"] == 1000
    assert f"is {committed['median_coverage']:.3g} and the smallest {committed['smallest_coverage']:.3g}" in docs


def test_an_earlier_protocols_table_gives_its_learner_against_its_chosen_best_rule():
    found = populations(Path("results/protocol_v3/pid-fixed-default/test_per_plant.csv.gz"))
    assert [(p["learner"], p["rule"], p["differences"].shape) for p in found] == [
        ("learned-fixed-cert-3000", "amigo-pid", (10, 4000))]


def test_the_committed_coverage_with_twenty_seeds_is_the_one_docs_protocol_quotes():
    committed = json.loads(Path("results/protocol_coverage/seeds_random_20_seeds.json").read_text())
    assert committed["populations"][0]["seeds_resampled"] == 20
    assert (f"the smallest is {committed['smallest_coverage']:.3g} (median {committed['median_coverage']:.3g})"
            in Path("docs/protocol.md").read_text())
