"""The protocol file: v1 as committed, the schema's refusals, and the refusal of a changed protocol."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from agents.protocol.config import load_protocol
from agents.protocol.report import _declared
from agents.protocol.run import ProtocolRefused, start
from agents.protocol.streams import check_test_seed, plant_stream, read_registry, register_test_seed

V1 = Path("configs/protocols/v1.yaml")


def test_v1_declares_the_study_and_its_test_seed_is_registered_to_it():
    protocol = load_protocol(V1)
    assert len(protocol.regimes) == 15 and _declared(protocol) == 51
    assert protocol.validation.plants >= 2000 and protocol.test.plants >= 2000 and len(protocol.seeds) == 10
    entry = check_test_seed(protocol.test.entropy, protocol.sha256, V1.with_name("test_seeds.json"))
    assert entry["protocol"] == str(V1)
    entropies = [e["entropy"] for e in read_registry(V1.with_name("test_seeds.json"))]
    assert len(set(entropies)) == len(entropies)


def test_streams_are_prefix_stable_and_differ_from_the_fixed_sets():
    from envs.systems.plant_sets import PLANT_SET_ENTROPY, plant_set

    ten, three = plant_stream("stable", 11, 10), plant_stream("stable", 11, 3)
    assert [p.to_dict() for p in three] == [p.to_dict() for p in ten[:3]]
    assert ten[0].to_dict() != plant_set("stable", "test", 1)[0].to_dict()
    with pytest.raises(ValueError, match="fixed validation and test sets"):
        plant_stream("stable", PLANT_SET_ENTROPY, 1)


def _copy(tmp_path: Path, change: str = "") -> Path:
    folder = tmp_path / "protocols"
    folder.mkdir(exist_ok=True)
    path = folder / "v1.yaml"
    path.write_text(V1.read_text() + change)
    shutil.copy(V1.with_name("test_seeds.json"), folder / "test_seeds.json")
    return path


def test_a_changed_protocol_is_refused_on_the_registered_test_seed(tmp_path):
    protocol = load_protocol(_copy(tmp_path, "# a changed comment changes the protocol\n"))
    with pytest.raises(ProtocolRefused, match="a changed protocol takes a fresh test seed"):
        start(protocol, tmp_path / "out", resume=False)
    with pytest.raises(ValueError, match="already registered"):
        register_test_seed(protocol.test.entropy, protocol.path, protocol.sha256, Path(protocol.path).with_name("test_seeds.json"))


def test_a_run_folder_of_another_protocol_is_refused(tmp_path):
    protocol = load_protocol(_copy(tmp_path))
    out = tmp_path / "out"
    start(protocol, out, resume=False)
    with pytest.raises(ProtocolRefused, match="--resume"):
        start(protocol, out, resume=False)
    assert start(protocol, out, resume=True)["protocol_sha256"] == protocol.sha256
    record = json.loads((out / "protocol.json").read_text())
    (out / "protocol.json").write_text(json.dumps({**record, "protocol_sha256": "0" * 64}))
    with pytest.raises(ProtocolRefused, match="a changed protocol takes a fresh test seed"):
        start(protocol, out, resume=True)


def test_the_command_refuses_a_changed_protocol_in_one_line(tmp_path):
    path = _copy(tmp_path, "# changed\n")
    done = subprocess.run([sys.executable, "-m", "agents.cli", "protocol", "run", str(path), "--out", str(tmp_path / "out")],
                          capture_output=True, text=True)
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1 and "fresh test seed" in done.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("edit, message", [
    (("name: v1", "name: v1\nextra: 1"), "unknown key 'extra'"),
    (("plants: 4000", "plants: 1"), "streams.test.plants must be an integer >= 2"),
    (("comparisons: [[fixed, best-rule]", "comparisons: [[fixed, oracle]"), r"comparisons\[0\]"),
    (("config: configs/learned_plan.yaml", "config: configs/missing.yaml"), "no such file"),
])
def test_bad_protocols_are_refused_naming_what_is_wrong(tmp_path, edit, message):
    path = tmp_path / "bad.yaml"
    path.write_text(V1.read_text().replace(*edit, 1))
    with pytest.raises(ValueError, match=message):
        load_protocol(path)


def test_the_committed_coverage_check_holds_and_the_docs_quote_it():
    coverage = json.loads(Path("results/protocol_coverage/coverage.json").read_text())
    assert coverage["n"] == load_protocol(V1).test.plants and coverage["replicates"] == 4000
    envs = {population["env"] for population in coverage["populations"]}
    assert envs == {"PID-v3", "FPPI-v3"} and len(coverage["populations"]) == 156
    assert coverage["smallest_coverage"]["0.95"] >= 0.93
    text = Path("docs/protocol.md").read_text()
    for level, error in coverage["monte_carlo_standard_error_at_nominal"].items():
        assert f"{coverage['smallest_coverage'][level]:g}" in text and f"{error:.2g}" in text


def test_a_retired_test_seed_is_never_evaluated(tmp_path):
    registry = tmp_path / "test_seeds.json"
    registry.write_text(json.dumps([{"entropy": 5, "protocol": "p.yaml", "sha256": "a" * 64, "superseded_by": "b" * 64}]))
    with pytest.raises(ValueError, match="retired"):
        check_test_seed(5, "a" * 64, registry)


def test_a_training_config_changed_after_the_start_is_refused(tmp_path):
    protocol = load_protocol(_copy(tmp_path))
    out = tmp_path / "out"
    record = start(protocol, out, resume=False)
    config = next(iter(record["configs_sha256"]))
    (out / "protocol.json").write_text(json.dumps({**record, "configs_sha256": {config: "0" * 64}}))
    with pytest.raises(ProtocolRefused, match=f"{config} changed since the run"):
        start(protocol, out, resume=True)


@pytest.mark.parametrize("edit, message", [
    (("comparisons: [[fixed, best-rule]", "comparisons: [[fixed, fixed], [fixed, best-rule]"), r"comparisons\[0\]"),
    (("comparisons: [[fixed, best-rule]", "comparisons: [[seq, oracle], [fixed, best-rule]"), r"comparisons\[0\]"),
])
def test_a_primary_is_compared_with_another_one_never_with_itself(tmp_path, edit, message):
    path = tmp_path / "bad.yaml"
    path.write_text(V1.read_text().replace(*edit, 1))
    with pytest.raises(ValueError, match=message):
        load_protocol(path)


def test_a_label_names_the_candidates_of_one_primary_only(tmp_path):
    path = tmp_path / "bad.yaml"
    text = V1.read_text().replace("    plan:\n      - {label: learned-plan,", "    seq:\n      - {label: learned-fixed, config: configs/sequential.yaml}\n    plan:\n      - {label: learned-plan,", 1)
    path.write_text(text)
    with pytest.raises(ValueError, match="'learned-fixed' names candidates of two primaries"):
        load_protocol(path)


def test_v4_declares_the_sequential_agent_against_the_learned_own_plan_and_its_test_seed_is_registered_to_it():
    path = V1.with_name("v4.yaml")
    protocol = load_protocol(path)
    assert [regime.name for regime in protocol.regimes] == ["pid-noise10-time", "msp-noise10-production"]
    assert all(not regime.fixed and [learner.label for learner in regime.seq] == ["seq-maskable-ppo"]
               and [learner.label for learner in regime.plan] == ["learned-plan-own-3000"] for regime in protocol.regimes)
    assert _declared(protocol) == 8 and protocol.test.plants >= 2000 and len(protocol.seeds) == 10
    assert check_test_seed(protocol.test.entropy, protocol.sha256, path.with_name("test_seeds.json"))["protocol"] == str(path)


def test_a_regime_without_candidates_is_refused(tmp_path):
    path = tmp_path / "bad.yaml"
    text = V1.with_name("v4.yaml").read_text()
    start = text.index("  - name: msp-noise10-production")
    path.write_text(text[:start] + "  - name: empty\n    env: DeadTime/MSP-v3\n")
    with pytest.raises(ValueError, match=r"regimes\[1\] has no candidates"):
        load_protocol(path)
