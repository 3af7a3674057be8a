"""The shipped learners: loaded against their manifests, played by name in each structure, refused when damaged."""

import shutil

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from agents.risk.labels import STRUCTURES
from agents.risk.pretrained import PRETRAINED_DIR, load_learner, load_pretrained, model_paths


@pytest.mark.parametrize("structure", STRUCTURES)
def test_the_shipped_learner_loads_and_plays_an_episode_without_training(structure):
    policy = load_pretrained(f"learned-{structure.lower()}@0.01")
    assert policy.env_id == f"DeadTime/{structure}-v3" and policy.manifest["structure"] == structure
    env = gym.make(policy.env_id, **policy.env_kwargs)
    observation, _ = env.reset(seed=12345)
    action, _ = policy.predict(observation)
    assert action.shape == env.action_space.shape and env.action_space.contains(action)
    _, reward, terminated, _, info = env.step(action)
    assert terminated and np.isfinite(info["cost"]) and reward == -info["cost"]
    # a smaller risk is never a bolder design
    bolder = load_pretrained(f"learned-{structure.lower()}@0.2").predict(observation)[0]
    assert bolder[0] <= action[0]


def test_a_name_plays_in_the_evaluation_and_a_wrong_structure_is_one_line():
    from agents.evaluation.evaluate import evaluate
    from envs.systems.families import sample_plant

    plant = sample_plant("stable", np.random.default_rng(987654321))
    result = evaluate("DeadTime/PID-v3", "learned-pid@0.05", plants=[plant], seed=5, benchmark=False, plots=False)
    assert "learned-pid@0.05" in [row["name"] for row in result["policies"]]
    with pytest.raises(ValueError, match="trained on DeadTime/PID-v3, not DeadTime/FPPI-v3"):
        evaluate("DeadTime/FPPI-v3", "learned-pid@0.05", plants=[plant], seed=5, benchmark=False, plots=False)
    with pytest.raises(ValueError, match=r"in \(0, 0.5\)"):
        evaluate("DeadTime/PID-v3", "learned-pid@0.5", plants=[plant], seed=5, benchmark=False, plots=False)


def test_a_changed_model_file_is_refused(tmp_path):
    model, manifest = model_paths("PI")
    shutil.copy(manifest, tmp_path / manifest.name)
    data = bytearray(model.read_bytes())
    data[len(data) // 2] ^= 1
    (tmp_path / model.name).write_bytes(bytes(data))
    with pytest.raises(ValueError, match="damaged or missing"):
        load_learner("PI", tmp_path)
    with pytest.raises(ValueError, match="no pretrained"):
        load_learner("PID", tmp_path)


def test_the_manifests_name_the_committed_config_and_the_choice():
    import json

    from agents.risk.config import load_config

    config = load_config("configs/risk_learner.yaml")
    for structure in STRUCTURES:
        learner, record, _ = load_learner(structure)
        assert record["structure"] == structure and record["config"] == json.loads(json.dumps(config.to_dict()))
        assert record["config"]["training_plants"] >= 20000 and record["config"]["quantized_share"] > 0
        chosen = {"model": record["model"], "bands": record["bands"], "quantized_band": record["quantized_band"]}
        assert record["chosen"] == chosen and record["commit"]
        space = gym.make(record["env_id"]).observation_space
        assert learner.observation_size == space.shape[0]


@pytest.mark.slow
def test_a_retrain_on_a_few_plants_gives_the_same_predictions(tmp_path):
    from agents.risk.config import RiskLearnerConfig
    from agents.risk.train import pretrain_structure

    config = RiskLearnerConfig(structures=("PI",), training_plants=60, validation_plants=20, models=("boosting",), bands=(1,))
    first = pretrain_structure(config, "PI", tmp_path / "labels-1", tmp_path / "models-1", log=None)
    second = pretrain_structure(config, "PI", tmp_path / "labels-2", tmp_path / "models-2", log=None)
    rows = np.random.default_rng(0).normal(size=(50, load_learner("PI", first.parent)[0].observation_size))
    for risk in (0.01, 0.05, 0.3):
        assert np.array_equal(load_learner("PI", first.parent)[0].design(rows, risk),
                              load_learner("PI", second.parent)[0].design(rows, risk))


def test_a_shipped_learner_is_checked_against_its_own_training_range():
    from agents.evaluation.process_policies import out_of_distribution

    policy = load_pretrained("learned-fppi@0.01")
    low, high = policy.feature_ranges["log_noise_ratio"]
    assert high - low > 1.5  # trained across noise levels, not one
    names = tuple(policy.feature_ranges)
    inside = np.array([sum(policy.feature_ranges[name]) / 2 for name in names])
    assert out_of_distribution(policy.env_id, policy.env_kwargs, names, inside, policy.feature_ranges) is None
    outside = np.where(np.array(names) == "log_noise_ratio", high + 1.0, inside)
    assert "log_noise_ratio" in out_of_distribution(policy.env_id, policy.env_kwargs, names, outside, policy.feature_ranges)


def test_a_risk_below_a_bands_share_without_a_feasible_design_warns_on_loading():
    learner, _, _ = load_learner("MSP")
    risk = 0.005
    floors = learner.unreachable(risk)
    assert floors and all(floor >= risk * 0.9 for floor in floors)  # MSP at high noise: a few % of plants with no design
    with pytest.warns(UserWarning, match="no feasible design"):
        policy = load_pretrained(f"learned-msp@{risk}")
    rows = np.zeros((1, learner.observation_size))
    assert policy.reachable(rows).shape == (1,) and policy.floor(rows).shape == (1,)
    assert not learner.unreachable(0.2)
