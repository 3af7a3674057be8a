"""Hostile and careless protocol files, run folders and registries: refused at load or where they are
used, in one line, before anything is trained or written."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from in_process import run_deadtime as run
from tiny_protocol import write_tiny_protocol

from agents.protocol.config import load_protocol
from agents.protocol.every_rule import write_every_rule
from agents.protocol.report import write_report
from agents.protocol.run import PER_PLANT, SUMMARY, _write_table, start
from agents.protocol.streams import read_registry


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# ------------------------------------------------------------------------------------- names
@pytest.mark.parametrize("name", ["..", ".", "", "a/b", "a\\\\b", "/tmp/x", "a\\0b", "-x", " x"])
@pytest.mark.parametrize("field", ["name: pid-tiny", "label: tiny-fixed"])
def test_a_name_that_is_not_a_plain_file_name_is_refused_at_load(tmp_path, field, name):
    key = field.split(":")[0]
    path = write_tiny_protocol(tmp_path, edits=((field, f'{key}: "{name}"'),))
    where = r"regimes\[0\]\.name" if key == "name" else r"regimes\[0\]\.fixed\[0\]\.label"
    with pytest.raises(ValueError, match=f"{where} must be a plain file name") as error:
        load_protocol(path)
    assert "\n" not in str(error.value)


def test_a_regime_named_dot_dot_writes_nothing_beside_the_run_folder(tmp_path):
    """``protocol run``, ``every-rule`` and ``report`` with a regime named ``..``: refused, the parent of
    ``--out`` unchanged."""
    path = write_tiny_protocol(tmp_path, edits=(("name: pid-tiny", 'name: ".."'),))
    (tmp_path / "selection.json").write_text("mine")
    before = _files(tmp_path)
    for action in ("run", "every-rule", "report"):
        status, _, err = run("protocol", action, str(path), "--out", str(tmp_path / "out"))
        assert status == 2 and len(err.strip().splitlines()) == 1 and "plain file name" in err
    assert _files(tmp_path) == before and not (tmp_path / "out").exists()


# ------------------------------------------------------------------------------------- every name before any fit
@pytest.mark.parametrize("edit, message", [
    (("rules: [simc-pi, gorez-klan-mu-2]", "rules: [simc-pi, no-such-rule]"), r"selection\.rules\[1\]: 'no-such-rule' is not a rule"),
    (("rules: [simc-pi, gorez-klan-mu-2]", "rules: [oracle]"), r"selection\.rules\[0\]: 'oracle' is not a rule"),
    (("rules: [simc-pi, gorez-klan-mu-2]", "rules: [plan-1-1]"), r"selection\.rules\[0\]: 'plan-1-1' is not a rule"),
    (("plans: [plan-1-1, plan-3-0.1]", "plans: [plan-1-1, plan-x]"), r"selection\.plans\[1\]: 'plan-x' is not a procedure"),
    (("plans: [plan-1-1, plan-3-0.1]", "plans: [plan-best]"), r"selection\.plans\[0\]: 'plan-best'"),
    (("plans: [plan-1-1, plan-3-0.1]", "plans: [plan-1-1, plan-1-1]"), r"selection\.plans names 'plan-1-1' twice"),
    (("fixed_procedure: plan-1-1", "fixed_procedure: simc-pi"), r"selection\.fixed_procedure: 'simc-pi' is not a procedure"),
    (("fixed_procedure: plan-1-1", "fixed_procedure: plan-1000-1"), r"selection\.fixed_procedure: "),
    (("plans: [plan-1-1, plan-3-0.1]", "plans: []"), r"comparisons\[3\] \['plan', 'best-plan'\] is made in no regime"),
    (("    plan:\n      - {label: tiny-plan", "    seq:\n      - {label: tiny-plan"), r"comparisons\[1\] .* is made in no regime"),
    (("[plan, best-plan]]", "[plan, best-plan], [fixed, best-rule]]"), r"comparisons\[4\] declares .* a second time"),
])
def test_every_name_of_the_protocol_is_checked_at_load_naming_its_field(tmp_path, edit, message):
    """An unknown rule, plan or fixed procedure, ``oracle`` as a rule, a comparison no regime makes: refused
    at load (by ``register`` too, which records nothing), naming the field, before any learner is trained."""
    path = write_tiny_protocol(tmp_path, edits=(edit,))
    with pytest.raises(ValueError, match=message):
        load_protocol(path)
    status, out, err = run("protocol", "register", str(path))
    assert status == 2 and len(err.strip().splitlines()) == 1 and not out
    assert not path.with_name("test_seeds.json").exists()


# ------------------------------------------------------------------------------------- the registry
def test_two_registrations_at_once_keep_both_entries(tmp_path):
    """Two processes registering at once beside one ``test_seeds.json``, round after round: every entry kept."""
    registry = tmp_path / "test_seeds.json"
    script = ("import sys; from pathlib import Path; from agents.protocol.streams import register_test_seed\n"
              "first, path = int(sys.argv[1]), Path(sys.argv[2])\n"
              "for k in range(12):\n"
              "    register_test_seed(first + k, f'p{first}.yaml', format(first + k, '064x'), path)\n")
    for round_ in range(3):
        registry.unlink(missing_ok=True)
        workers = [subprocess.Popen([sys.executable, "-c", script, str(first), str(registry)], stderr=subprocess.PIPE,
                                    text=True) for first in (1000, 2000)]
        for worker in workers:
            assert worker.wait(timeout=300) == 0, worker.stderr.read()
        entropies = sorted(entry["entropy"] for entry in read_registry(registry))
        assert entropies == [*range(1000, 1012), *range(2000, 2012)], f"round {round_}"
    assert [p.name for p in tmp_path.iterdir()] == ["test_seeds.json"]  # no lock nor temporary file left


@pytest.mark.parametrize("field, value, message", [
    ("sha256", 5, r"entry 0\.sha256 must be a sha256"),
    ("sha256", "abc", r"entry 0\.sha256 must be a sha256"),
    ("superseded_by", 7, r"entry 0\.superseded_by must be a sha256"),
    ("superseded_by", True, r"entry 0\.superseded_by must be a sha256"),
    ("entropy", "12", r"entry 0\.entropy must be an integer"),
    ("protocol", None, r"entry 0\.protocol must be the protocol's path"),
    ("extra", 1, r"entry 0 has the unknown field 'extra'"),
])
def test_a_registry_field_of_the_wrong_type_is_one_line(tmp_path, field, value, message):
    path = write_tiny_protocol(tmp_path)
    entry = {"entropy": 99, "protocol": "x.yaml", "sha256": "a" * 64, field: value}
    path.with_name("test_seeds.json").write_text(json.dumps([entry]))
    with pytest.raises(ValueError, match=message):
        read_registry(path.with_name("test_seeds.json"))
    for action in (["register", str(path)], ["run", str(path), "--out", str(tmp_path / "out")]):
        status, _, err = run("protocol", *action)
        assert status == 2 and len(err.strip().splitlines()) == 1 and "entry 0" in err
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------------------- report and every-rule
def _run_folder(tmp_path: Path, chosen: dict[str, str] | None = None, nan: bool = False) -> tuple[Path, Path]:
    """A protocol registered and a run folder of one tested regime with made-up per-plant costs."""
    path = write_tiny_protocol(tmp_path, register=True)
    protocol = load_protocol(path)
    out = tmp_path / "out"
    start(protocol, out, resume=False)
    chosen = chosen or {"best-rule": "simc-pi", "fixed-procedure": "plan-1-1", "best-plan": "plan-3-0.1",
                        "fixed": "tiny-fixed", "plan": "tiny-plan"}
    rng = np.random.default_rng(0)
    rows = []
    for policy, seeds in (("simc-pi", [""]), ("gorez-klan-mu-2", [""]), ("plan-1-1", [""]), ("plan-3-0.1", [""]),
                          ("oracle", [""]), ("tiny-fixed", ["0", "1"]), ("tiny-plan", ["0", "1"])):
        for seed in seeds:
            for plant in range(6):
                cost = float("nan") if nan and policy == "tiny-fixed" and plant == 2 else float(rng.uniform(1, 2))
                rows.append({"subset": "test", "plant": str(plant), "policy": policy, "seed": seed, "cost": cost,
                             "feasible": True})
    folder = out / "pid-tiny"
    folder.mkdir()
    _write_table(folder / PER_PLANT, rows)
    (folder / "selection.json").write_text(json.dumps({"regime": "pid-tiny", "family": "stable", "validation_plants": 5,
                                                       "chosen": chosen}))
    (folder / SUMMARY).write_text("{}")
    return path, out


def test_a_protocol_edited_after_its_run_is_not_reported(tmp_path):
    """alpha 0.05 -> 0.9 after the run: ``report`` and ``every-rule`` refuse it in one line, the folder unchanged."""
    path, out = _run_folder(tmp_path)
    assert write_report(load_protocol(path), out)["complete"]
    before = _files(out)
    path.write_text(path.read_text().replace("alpha: 0.05", "alpha: 0.9"))
    for action in ("report", "every-rule"):
        status, _, err = run("protocol", action, str(path), "--out", str(out))
        assert status == 2 and len(err.strip().splitlines()) == 1 and "changed after its run" in err, err
    assert _files(out) == before


def test_a_run_folder_of_another_protocol_is_not_reported(tmp_path):
    path, out = _run_folder(tmp_path)
    other = tmp_path / "other"
    other.mkdir()
    other_path, other_out = _run_folder(other)
    (out / "protocol.json").write_bytes((other_out / "protocol.json").read_bytes())
    with pytest.raises(ValueError, match="another protocol's"):
        write_report(load_protocol(path), out)
    with pytest.raises(ValueError, match="another protocol's"):
        write_every_rule(load_protocol(path), out)
    with pytest.raises(ValueError, match="holds no protocol run"):
        write_report(load_protocol(path), tmp_path / "protocols")


def test_a_selection_naming_a_policy_the_table_lacks_is_one_line(tmp_path):
    path, out = _run_folder(tmp_path, chosen={"best-rule": "amigo-pid", "fixed": "tiny-fixed"})
    status, _, err = run("protocol", "report", str(path), "--out", str(out))
    assert status == 2 and len(err.strip().splitlines()) == 1
    assert "selection.json chooses 'amigo-pid' as best-rule" in err and "does not score" in err


def test_a_declared_comparison_that_cannot_be_made_is_reported_as_such(tmp_path):
    """A comparison the regime should make but its selection cannot: listed as not made, the family incomplete."""
    path, out = _run_folder(tmp_path, chosen={"best-rule": "simc-pi", "fixed-procedure": "plan-1-1",
                                              "best-plan": "plan-3-0.1", "fixed": "tiny-fixed"})
    results = write_report(load_protocol(path), out)
    assert not results["complete"] and (results["comparisons_done"], results["comparisons_declared"]) == (1, 4)
    assert [item["roles"] for item in results["regimes"][0]["not_made"]] == [
        ["plan", "best-rule"], ["plan", "fixed-procedure"], ["plan", "best-plan"]]
    assert "Not made: pid-tiny, plan - best-rule" in (out / "results.md").read_text()


def test_a_nan_cost_is_not_read_as_a_tie(tmp_path):
    path, out = _run_folder(tmp_path, nan=True)
    status, _, err = run("protocol", "report", str(path), "--out", str(out))
    assert status == 2 and len(err.strip().splitlines()) == 1 and "not a finite number" in err
    assert not (out / "protocol_results.json").exists()


def test_every_rule_on_a_folder_with_no_regime_tested_fails(tmp_path):
    path, out = _run_folder(tmp_path)
    (out / "pid-tiny" / SUMMARY).unlink()
    status, _, err = run("protocol", "every-rule", str(path), "--out", str(out))
    assert status == 2 and "no regime of" in err and len(err.strip().splitlines()) == 1
    empty = tmp_path / "empty"
    empty.mkdir()
    status, _, err = run("protocol", "every-rule", str(path), "--out", str(empty))
    assert status == 2 and "holds no protocol run" in err and not (empty / "every_rule.md").exists()


# ------------------------------------------------------------------------------------- coverage
@pytest.mark.parametrize("option, value, message", [
    ("--n", "1000000000", "--n must be at most 10000"),
    ("--n", "1", "--n must be an integer >= 2"),
    ("--replicates", str(10**12), "--replicates must be at most"),
    ("--replicates", "0", "--replicates must be an integer >= 1"),
    ("--comparisons", "0", "--comparisons must be an integer >= 1"),
    ("--comparisons", "-5", "--comparisons must be an integer >= 1"),
    ("--seed", "-1", "--seed must be an integer >= 0"),
])
def test_coverage_is_bounded_and_refused_in_one_line(tmp_path, option, value, message):
    """Sizes far beyond honest use (``--n 1000000000``, ``--replicates 10**12``) and a family of no
    comparison: refused before any file is read."""
    out = tmp_path / "coverage.json"
    status, printed, err = run("protocol", "coverage", option, value, "--out", str(out))
    assert status == 2 and message in err and len(err.strip().splitlines()) == 1 and not printed
    assert not out.exists()


def test_a_cost_that_is_not_a_number_is_one_line_naming_the_table(tmp_path):
    import gzip

    path, out = _run_folder(tmp_path)
    table = out / "pid-tiny" / PER_PLANT
    text = gzip.decompress(table.read_bytes()).decode().splitlines()
    text[1] = ",".join([*text[1].split(",")[:4], "cheap", "True"])
    table.write_bytes(gzip.compress(("\n".join(text) + "\n").encode()))
    status, _, err = run("protocol", "report", str(path), "--out", str(out))
    assert status == 2 and len(err.strip().splitlines()) == 1 and f"{table}:" in err
