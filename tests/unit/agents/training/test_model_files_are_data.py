"""Loading a model executes nothing from its files: a planted pickle never runs, and is refused in one line.

Each hostile file below is a pickle whose loading would create a marker file.  It is planted as a
learned rule's or a selector's model (with its manifest rewritten to match, as whoever can write the
folder can), as an agent's zip ``data`` entry or ``policy.pth``, as ``model.vecnormalize.pkl``, and
as a ``best_model.zip`` beside a verified ``model.zip``.  ``deadtime evaluate`` must exit 2 with one
line, and the marker must not appear.  Models of the older formats are converted by ``deadtime
convert-model --trust`` and then predict bit for bit what they did.
"""

from __future__ import annotations

import io
import json
import pickle
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from agents.cli import main


class Payload:
    """Unpickled, creates ``marker`` (a stand-in for any code)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (Path.touch, (Path(self.marker),))


def _payload(marker: Path) -> bytes:
    return pickle.dumps(Payload(marker))


def _evaluate(capsys, policy: str, out: Path, env: str = "DeadTime/PID-v3") -> tuple[int, str]:
    status = main(["evaluate", "--env", env, "--policies", policy, "--n", "1", "--no-plots", "--out", str(out)])
    return status, capsys.readouterr().err


def _fitted_manifest(folder: Path, name: str, content: bytes, env_id: str = "DeadTime/PID-v3") -> None:
    """A model file ``name`` of ``content`` and a manifest of the older format that matches it."""
    import hashlib

    from agents.runtime import versions

    (folder / name).write_bytes(content)
    manifest = {"format": 1, "file": name, "size": len(content), "sha256": hashlib.sha256(content).hexdigest(),
                "versions": versions(), "env_id": env_id, "env_kwargs": {}}
    stem = name.split(".")[0]
    (folder / f"{stem}.json").write_text(json.dumps(manifest))


@pytest.mark.parametrize("stem", ["learned_rule", "selector"])
@pytest.mark.parametrize("suffix", ["pkl", "skops"])
def test_a_planted_pickle_with_a_matching_manifest_never_runs(tmp_path: Path, capsys, stem: str, suffix: str) -> None:
    marker = tmp_path / "marker"
    folder = tmp_path / "fit"
    folder.mkdir()
    _fitted_manifest(folder, f"{stem}.{suffix}", _payload(marker))
    status, err = _evaluate(capsys, f"planted={folder}", tmp_path / "out")
    assert not marker.exists()
    assert status == 2 and err.count("\n") == 1 and f"{folder / stem}.{suffix}" in err, err


def test_a_skops_file_naming_an_untrusted_type_is_refused_by_name(tmp_path: Path, capsys) -> None:
    import os

    import skops.io

    folder = tmp_path / "fit"
    folder.mkdir()
    _fitted_manifest(folder, "learned_rule.skops", skops.io.dumps({"run": os.system}))
    status, err = _evaluate(capsys, f"planted={folder}", tmp_path / "out")
    assert status == 2 and err.count("\n") == 1 and "names types that are not trusted" in err and "system" in err, err


def _tiny_rule():
    from baselines.learned_rule import LearnedRule, fit_regression, fit_spread

    rng = np.random.default_rng(0)
    x = rng.normal(size=(120, 3))
    y = x[:, 0] - 0.5 * x[:, 1] ** 2 + 0.1 * rng.normal(size=120)
    rule = LearnedRule("boosting", fit_regression("boosting", x, y), 0.1, -1.0, -4.0, 4.0, 3, fit_spread(x, y))
    return rule, rng.normal(size=(200, 3))


def test_a_learned_rule_is_saved_as_data_and_read_back_exactly(tmp_path: Path) -> None:
    from agents.training.learned_rule_policy import load_learned_rule, save_learned_rule

    rule, observations = _tiny_rule()
    save_learned_rule(tmp_path, rule, {"env_id": "DeadTime/PID-v3", "env_kwargs": {}})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["learned_rule.json", "learned_rule.skops"]
    loaded = load_learned_rule(tmp_path)
    assert np.array_equal(loaded.predict(observations)[0], rule.predict(observations))


def test_an_older_pickled_learned_rule_is_refused_then_converted_bit_for_bit(tmp_path: Path, capsys) -> None:
    from agents.training.learned_rule_policy import load_learned_rule

    rule, observations = _tiny_rule()
    folder = tmp_path / "fit"
    folder.mkdir()
    _fitted_manifest(folder, "learned_rule.pkl", pickle.dumps(rule))
    with pytest.raises(ValueError, match=f"is a pickle, which is not loaded .*deadtime convert-model {folder} --trust"):
        load_learned_rule(folder)
    assert main(["convert-model", str(folder)]) == 2
    assert "--trust" in capsys.readouterr().err and (folder / "learned_rule.pkl").exists()
    assert main(["convert-model", str(folder), "--trust"]) == 0
    assert not (folder / "learned_rule.pkl").exists()
    converted = load_learned_rule(folder)
    assert converted.manifest["env_id"] == "DeadTime/PID-v3" and converted.path.name == "learned_rule.skops"
    assert np.array_equal(converted.predict(observations)[0], rule.predict(observations))


# ----------------------------------------------------------------------------------- agents
def _rezip(path: Path, replace: dict[str, bytes]) -> None:
    """Rewrite the zip at ``path`` with some entries replaced."""
    with zipfile.ZipFile(path) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    entries.update(replace)
    with zipfile.ZipFile(path, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)


def _remanifest(folder: Path, stem: str, names: list[str]) -> None:
    """Rewrite ``<stem>.manifest.json`` to match ``names`` (as whoever can write the folder can)."""
    from agents.training.manifest import write_manifest

    write_manifest(folder / f"{stem}.zip", [folder / name for name in names])


def _serialized_payload(marker: Path) -> str:
    """A ``data`` entry that is JSON, with a payload where stable-baselines3 keeps a cloudpickled object."""
    import base64

    return json.dumps({"policy_class": {":type:": "<class 'abc.ABCMeta'>",
                                        ":serialized:": base64.b64encode(_payload(marker)).decode()},
                       "deadtime_vecnormalize": True})


def _data_pickle(folder: Path, marker: Path) -> str:
    _rezip(folder / "model.zip", {"data": _payload(marker)})
    _remanifest(folder, "model", ["model.zip", "model.normalization.json"])
    return "its 'data' entry is missing or not JSON"


def _policy_pickle(folder: Path, marker: Path) -> str:
    import torch

    buffer = io.BytesIO()
    torch.save({"weights": Payload(marker)}, buffer)
    _rezip(folder / "model.zip", {"policy.pth": buffer.getvalue()})
    _remanifest(folder, "model", ["model.zip", "model.normalization.json"])
    return "its policy.pth is missing or holds more than tensors"


def _statistics_pickle(folder: Path, marker: Path) -> str:
    (folder / "model.normalization.json").unlink()
    (folder / "model.vecnormalize.pkl").write_bytes(_payload(marker))
    _remanifest(folder, "model", ["model.zip", "model.vecnormalize.pkl"])
    return "model.vecnormalize.pkl is a pickle, which is not loaded"


def _statistics_pickle_without_manifest(folder: Path, marker: Path) -> str:
    _statistics_pickle(folder, marker)
    (folder / "model.manifest.json").unlink()
    return "model.zip has no manifest"


def _data_pickle_without_manifest(folder: Path, marker: Path) -> str:
    _rezip(folder / "model.zip", {"data": _payload(marker)})
    (folder / "model.manifest.json").unlink()
    return "model.zip has no manifest"


def _serialized_data_without_manifest(folder: Path, marker: Path) -> str:
    _rezip(folder / "model.zip", {"data": _serialized_payload(marker).encode()})
    (folder / "model.manifest.json").unlink()
    return "model.zip has no manifest"


def _best_model(folder: Path, marker: Path) -> str:
    shutil.copy(folder / "model.zip", folder / "best_model.zip")
    _rezip(folder / "best_model.zip", {"data": _serialized_payload(marker).encode()})
    shutil.copy(folder / "model.normalization.json", folder / "best_model.normalization.json")
    return "best_model.zip has no manifest"


PLANTED = [_data_pickle, _policy_pickle, _statistics_pickle, _statistics_pickle_without_manifest,
           _data_pickle_without_manifest, _serialized_data_without_manifest, _best_model]


@pytest.mark.parametrize("plant", PLANTED, ids=lambda f: f.__name__.strip("_"))
def test_a_planted_pickle_in_an_agent_never_runs(tiny_agent, tmp_path: Path, capsys, plant) -> None:
    folder = tmp_path / "run"
    shutil.copytree(tiny_agent[0], folder)
    marker = tmp_path / "marker"
    message = plant(folder, marker)
    status, err = _evaluate(capsys, f"agent={folder}", tmp_path / "out", env="DeadTime/FPPI-v0")
    assert not marker.exists()
    assert status == 2 and err.count("\n") == 1 and message in err and str(folder) in err, err


def test_serialized_objects_in_data_are_never_deserialized(tiny_agent, tmp_path: Path) -> None:
    from agents.training.policies import load_policy

    folder = tmp_path / "run"
    shutil.copytree(tiny_agent[0], folder)
    marker = tmp_path / "marker"
    _rezip(folder / "model.zip", {"data": _serialized_payload(marker).encode()})
    _remanifest(folder, "model", ["model.zip", "model.normalization.json"])
    loaded = load_policy(folder)
    assert not marker.exists() and loaded.path == folder / "model.zip"


def _sb3_actions(model, venv, observations: np.ndarray) -> np.ndarray:
    return model.predict(venv.normalize_obs(observations), deterministic=True)[0]


def test_a_loaded_agent_plays_as_the_trained_one_bit_for_bit(tiny_agent) -> None:
    from agents.training.policies import load_policy

    folder, model, venv = tiny_agent
    observations = np.random.default_rng(1).normal(size=(64, venv.observation_space.shape[0])).astype(np.float32)
    loaded = load_policy(folder)
    assert np.array_equal(loaded.predict(observations)[0], _sb3_actions(model, venv, observations))


def test_an_older_agent_is_refused_then_converted_bit_for_bit(tmp_path: Path, capsys, agent_saver) -> None:
    from agents.training.policies import load_policy

    folder, model, venv = agent_saver(tmp_path / "run", legacy=True)
    status, err = _evaluate(capsys, f"agent={folder}", tmp_path / "out", env="DeadTime/FPPI-v0")
    assert status == 2 and err.count("\n") == 1 and f"deadtime convert-model {folder / 'model.zip'} --trust" in err, err
    assert main(["convert-model", str(folder), "--trust"]) == 0
    assert not (folder / "model.vecnormalize.pkl").exists()
    observations = np.random.default_rng(2).normal(size=(64, venv.observation_space.shape[0])).astype(np.float32)
    loaded = load_policy(folder)
    assert np.array_equal(loaded.predict(observations)[0], _sb3_actions(model, venv, observations))


def test_an_agent_saved_by_stable_baselines3_directly_is_converted_with_its_environment(tmp_path: Path, capsys) -> None:
    from stable_baselines3 import SAC
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from agents.environments import make_env
    from agents.training.policies import load_policy

    folder = tmp_path / "elsewhere"
    folder.mkdir()
    venv = VecNormalize(DummyVecEnv([lambda: make_env("DeadTime/FPPI-v0", {})]))
    model = SAC("MlpPolicy", venv, learning_starts=4, batch_size=4, buffer_size=100, device="cpu", seed=3,
                policy_kwargs={"net_arch": [5], "activation_fn": __import__("torch").nn.Tanh})
    model.learn(8)
    model.save(folder / "agent.zip")
    with (folder / "agent.vecnormalize.pkl").open("wb") as handle:
        pickle.dump(venv, handle)
    status, err = _evaluate(capsys, f"a={folder / 'agent.zip'}", tmp_path / "out", env="DeadTime/FPPI-v0")
    assert status == 2 and err.count("\n") == 1 and "agent.zip has no manifest" in err, err
    assert main(["convert-model", str(folder / "agent.zip"), "--trust"]) == 2
    assert "pass --env ID" in capsys.readouterr().err
    assert main(["convert-model", str(folder / "agent.zip"), "--trust", "--env", "DeadTime/FPPI-v0"]) == 0
    loaded = load_policy(folder / "agent.zip")
    assert loaded.algorithm == "SAC" and loaded.config.policy_kwargs["activation_fn"] == "tanh"
    observations = np.random.default_rng(3).normal(size=(64, venv.observation_space.shape[0])).astype(np.float32)
    assert np.array_equal(loaded.predict(observations)[0], _sb3_actions(model, venv, observations))


def test_an_older_pickled_selector_is_converted_bit_for_bit_with_its_own_learned_design(tmp_path: Path) -> None:
    from sklearn.ensemble import HistGradientBoostingClassifier, HistGradientBoostingRegressor

    from agents.training.learned_rule_policy import load_learned_rule
    from agents.training.selector_policy import Selector, load_selector

    rule, observations = _tiny_rule()
    x = np.random.default_rng(4).normal(size=(150, 3))
    selector = Selector(("simc-pi", "learned"), ("simc-pi", None), {"learned": rule},
                        (HistGradientBoostingClassifier(random_state=0).fit(x, x[:, 0] > 0), 0.25),
                        (HistGradientBoostingRegressor(random_state=0).fit(x, x[:, 1]), 1.5), 0.2)
    folder = tmp_path / "fit"
    (folder / "learned").mkdir(parents=True)
    _fitted_manifest(folder, "selector.pkl", pickle.dumps(selector))
    _fitted_manifest(folder / "learned", "learned_rule.pkl", pickle.dumps(rule))
    assert main(["convert-model", str(folder), "--trust"]) == 0
    assert not list(folder.rglob("*.pkl"))
    converted = load_selector(folder)
    assert np.array_equal(converted.selector.choices(observations), selector.choices(observations))
    assert all(np.array_equal(a, b) for a, b in zip(converted.selector.predictions(observations),
                                                    selector.predictions(observations), strict=True))
    assert np.array_equal(converted.action("learned", observations), rule.predict(observations))
    assert np.array_equal(load_learned_rule(folder / "learned").predict(observations)[0], rule.predict(observations))


def test_deadtime_process_never_runs_a_planted_learned_rule(tmp_path: Path, capsys) -> None:
    marker = tmp_path / "marker"
    folder = tmp_path / "fit"
    folder.mkdir()
    _fitted_manifest(folder, "learned_rule.pkl", _payload(marker))
    status = main(["process", "--process", "tclab", "--policies", f"planted={folder}", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert not marker.exists()
    assert status == 2 and err.count("\n") == 1 and "learned_rule.pkl is a pickle, which is not loaded" in err, err
