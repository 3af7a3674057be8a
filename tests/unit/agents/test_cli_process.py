"""``deadtime process`` end to end, in process through ``agents.cli.main``.

* The TCLab: the JSON it prints, the files of ``--out``, the oracle ahead of the rule of its own
  structure; and the IAE the command reports for a controller equals a direct
  simulation with ``tclab`` (``TCLabModel(synced=False)``, ``random.seed``), the law written out here
  again from Marlin's equations, the protocol read from the JSON.  Measured: equal to rounding
  (relative differences below 1e-12) for a PI that never saturates and for a series PID at a limit
  18% of the time; the test allows 2%.
* The process path against the exact loop, through the command: ``--process module:factory`` with a :class:`PlantProcess`
  sampled at ``T_ar/500`` and ``--controller`` (the commissioning row) against ``deadtime analyze``:
  within 1% (measured 0.15% and 0.0%).
* Agents: a stand-in for ``load_policy`` (the observation it receives is the environment's for the
  process's experiments, and it ranks in the table); an agent-mode agent is a failure row; and
  (slow) a SAC agent trained for a few steps on ``DeadTime/PID-v0`` runs on the TCLab.
* Bad input is one line naming it, exit 2; a measurement that is not a number in a policy's tests
  stops those tests, the row says so, exit 0.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import random
import sys
import textwrap
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from in_process import run_deadtime

import envs  # noqa: F401
from agents.cli import main
from envs.interface import tuning_env_of


def run(*args: str) -> tuple[int, str, str]:
    return run_deadtime("process", *args)


@pytest.fixture(scope="module")
def tclab_result(tmp_path_factory) -> tuple[dict, Path]:
    out = tmp_path_factory.mktemp("tclab")
    status, printed, err = run("--process", "tclab", "--policies", "simc-pi,gorez-klan-mu-3,oracle", "--json", "--out", str(out))
    assert status == 0, err
    return json.loads(printed), out


def test_the_tclab_json_and_files(tclab_result):
    data, out = tclab_result
    assert data["process"] == "tclab"
    model = data["model"]
    assert model["gain"] == pytest.approx(0.60, rel=0.05) and model["residence_time"] == pytest.approx(157.6, rel=0.05)
    assert model["operating_point"]["input"] == 30.0 and model["commissioning"]["source"] == "open-loop step"
    assert model["relay"]["converged"]
    names = [p["name"] for p in data["policies"]]
    assert set(names) == {"commissioning", "simc-pi", "gorez-klan-mu-3", "oracle"}
    for policy in data["policies"]:
        for key in ("name", "controller", "iae_setpoint", "iae_load", "overshoot", "saturated_fraction", "model_ms",
                    "model_delay_margin"):
            assert key in policy
        assert policy["iae_setpoint"] > 0 and policy["iae_load"] > 0 and 0 <= policy["saturated_fraction"] <= 1
    by_name = {p["name"]: p for p in data["policies"]}
    assert by_name["oracle"]["cost"] <= by_name["gorez-klan-mu-3"]["cost"]  # the oracle bounds its own structure
    assert [p["rank"] for p in data["policies"]] == [1, 2, 3, 4]
    for name in ("results.md", "results.csv", "results.json", "experiments.png", "responses.png"):
        assert (out / name).is_file(), name
    assert json.loads((out / "results.json").read_text())["policies"] == data["policies"]


def _direct_iae(controller: dict, protocol: dict, setpoint_test: bool) -> float:
    """The test run with ``tclab`` itself: a new ``TCLabModel`` at ambient, ``random.seed``, heater 1 at
    the operating input for the settling time, then the PID law (ideal or series, derivative through
    the filter ``T_f = T_d/n``, anti-windup by external feedback) from the operating point."""
    import tclab

    with contextlib.redirect_stdout(io.StringIO()):
        lab = tclab.TCLabModel(synced=False)
    lab.tlast = 0.0
    state = random.getstate()
    random.seed(protocol["seed"])
    dt, time = 1.0, 0.0

    def sample(heater1: float, heater2: float) -> float:
        nonlocal time
        measured = lab.T1
        lab.Q1(heater1)
        lab.Q2(heater2)
        time += dt
        lab.update(time)
        return measured

    for _ in range(round(protocol["settle_time"] / dt)):
        sample(protocol["operating_input"], 0.0)
    kc, ti, td, n = controller["kp"], controller["ti"], controller["td"], controller["n"]
    tf = td / n if td > 0 else 0.0
    a = math.exp(-dt / tf) if tf > 0 else 0.0
    d_gain = td - tf if controller["type"] == "pid-series" else td
    target = protocol["operating_output"] + (protocol["setpoint_step"] if setpoint_test else 0.0)
    load = 0.0 if setpoint_test else protocol["load_step"]
    integral, filtered, errors = protocol["operating_input"], 0.0, []
    steps = math.ceil(protocol["horizon"] * protocol["residence_time"] / dt) + 1
    measured = lab.T1
    for _ in range(steps):
        e = target - measured
        errors.append(e)
        new = a * filtered + (1 - a) * e
        p = e + d_gain * (new - filtered) / dt
        filtered = new
        v = kc * p + integral
        u = min(max(v, 0.0), 100.0)
        integral += dt / ti * (kc * (p if controller["type"] == "pid-series" else e) + (u - v))
        lab.Q1(u)
        lab.Q2(load)
        time += dt
        lab.update(time)
        measured = lab.T1
    random.setstate(state)
    e = np.abs(errors)
    return float(np.sum(0.5 * (e[1:] + e[:-1])) * dt) if np.all(np.sign(errors[1:]) == np.sign(errors[:-1])) else \
        _trapezoid_split(np.asarray(errors), dt)


def _trapezoid_split(e: np.ndarray, dt: float) -> float:
    """``int |e|`` of the samples, linear between them, split at the sign changes."""
    total = 0.0
    for a, b in zip(e[:-1], e[1:]):
        total += 0.5 * (abs(a) + abs(b)) * dt if a * b >= 0 else 0.5 * (a * a + b * b) / (abs(a) + abs(b)) * dt
    return total


@pytest.mark.parametrize("name", ["simc-pi", "gorez-klan-mu-3"])
def test_the_reported_iae_is_a_direct_tclab_simulation(tclab_result, name):
    data, _ = tclab_result
    policy = next(p for p in data["policies"] if p["name"] == name)
    for key, setpoint_test in (("iae_setpoint", True), ("iae_load", False)):
        direct = _direct_iae(policy["controller"], data["protocol"], setpoint_test)
        assert policy[key] == pytest.approx(direct, rel=0.02)
        assert policy[key] == pytest.approx(direct, rel=1e-9)  # in fact to rounding (the same law and noise)
    if name == "gorez-klan-mu-3":
        assert policy["saturated_fraction"] > 0.1  # the anti-windup acts in this comparison


def _write_module(tmp_path: Path, monkeypatch, name: str, body: str) -> str:
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(body))
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop(name, None)
    return name


PLANT_MODULE = """
from envs.process.plant_process import PlantProcess
from envs.systems.plants import Plant

PLANT = Plant.from_time_constants(1.0, [10.0], 5.0)

def make():
    return PlantProcess(PLANT, sample_time=PLANT.residence_time / 500)
"""


def test_a_users_plant_process_reproduces_analyze_through_the_command(tmp_path, monkeypatch):
    from envs.analysis.loop_analysis import analyze
    from envs.systems.controllers import PID
    from envs.systems.plants import Plant

    module = _write_module(tmp_path, monkeypatch, "user_plant_process", PLANT_MODULE)
    controller = '{"type": "pid", "kp": 0.5, "ti": 10.0}'
    status, printed, err = run("--process", f"{module}:make", "--controller", controller, "--policies", "simc-pi", "--json")
    assert status == 0, err
    data = json.loads(printed)
    row = next(p for p in data["policies"] if p["name"] == "commissioning")
    assert data["model"]["commissioning"]["source"] == "given"
    analysis = analyze(Plant.from_time_constants(1.0, [10.0], 5.0), PID(kp=0.5, ti=10.0))
    assert row["iae_setpoint"] == pytest.approx(analysis.iae_setpoint, rel=0.01)
    assert row["iae_load"] == pytest.approx(analysis.iae_load, rel=0.01)


class _Constant:
    """A fixed-mode agent that records its observation and plays action 0 (the middle of ``mu``'s log range)."""

    name = "constant"
    env_id = None
    env_kwargs: dict = {}
    seen: list = []

    def predict(self, observation, deterministic=True):
        self.seen.append(np.array(observation))
        return np.zeros(1, dtype=np.float32), None


class _AgentMode(_Constant):
    name = "agent-mode"
    env_id = "DeadTime/PID-v0"
    env_kwargs = {"experiments": "agent"}


def test_an_agent_reads_the_environments_observation_and_ranks(tmp_path, monkeypatch):
    import agents.training.policies
    from agents.environments import make_env
    from agents.evaluation.process_policies import process_observation
    from envs.episode import evidence_from_identification
    from envs.episode_options import EpisodeOptions
    from envs.process.procedure import identify_process
    from envs.process.tclab_process import TCLabProcess

    monkeypatch.setattr(agents.training.policies, "load_policy", lambda path: _AgentMode() if "mode" in str(path) else _Constant())
    paths = []
    for name in ("constant", "agent-mode"):
        paths.append(tmp_path / f"{name}.zip")
        with zipfile.ZipFile(paths[-1], "w") as archive:
            archive.writestr("data", "{}")
    _Constant.seen.clear()
    status, printed, err = run("--process", "tclab", "--policies", f"simc-pi,const={paths[0]},{paths[1]}")
    assert status == 0, err
    assert "const (agent) ranks " in printed and " of 3" in printed
    assert "agent-mode (agent): the agent plays DeadTime/PID-v0 in agent mode" in printed
    # the observation is the one the environment builds from the same evidence
    found = identify_process(TCLabProcess())
    env = tuning_env_of(make_env("DeadTime/PID-v0"))
    env.evidence = evidence_from_identification(found.identification, EpisodeOptions(noise_std=found.noise_ratio))
    expected, _ = env.observation_and_features()
    assert np.array_equal(_Constant.seen[0], expected) and np.array_equal(process_observation(env, found), expected)
    assert _Constant.seen[0][5] == pytest.approx(math.log10(found.operating_point.noise_std / 10.0))  # noise / 10 degC


@pytest.mark.slow
@pytest.mark.parametrize("env_id", ["DeadTime/PID-v0", "DeadTime/PID-v3"])
def test_a_trained_agent_runs_on_the_tclab(tmp_path, env_id):
    config = tmp_path / "sac.yaml"
    config.write_text(textwrap.dedent(f"""
        default:
          env_id: {env_id}
          total_timesteps: 48
          seed: 1
          normalize: true
          eval_freq: 0
          checkpoint_freq: 0
          progress_bar: false
          policy_kwargs: {{net_arch: [16, 16]}}
          hyperparameters: {{learning_starts: 16, buffer_size: 1000, batch_size: 16}}
    """))
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["train", "--config", str(config), "--out", str(tmp_path / "run")]) == 0
    status, printed, err = run("--process", "tclab", "--policies", f"simc-pi,sac={tmp_path / 'run'}", "--json")
    assert status == 0, err
    row = next(p for p in json.loads(printed)["policies"] if p["name"] == "sac")
    assert row["role"] == "agent" and row["error"] is None and row["rank"] in (1, 2, 3)
    assert row["controller"]["type"] == "pid-series" and 0.3 <= row["parameter"] <= 300
    if env_id.endswith("v3"):  # the v3 observation's noise estimate of the quantized record is named
        assert "log_noise_ratio" in row["note"]


NAN_MODULE = """
import math
from envs.process.tclab_process import TCLabProcess

class Failing(TCLabProcess):
    '''NaN from sample {after} after every reset but the first {healthy}.'''

    resets = 0

    def reset(self, seed):
        super().reset(seed)
        self.resets += 1
        self.samples = 0

    def apply(self, control, load=0.0):
        super().apply(control, load)
        self.samples += 1

    def measure(self):
        bad = self.resets > {healthy} and self.samples >= {after}
        return math.nan if bad else super().measure()

def make():
    return Failing()
"""


def test_a_nan_in_a_policys_tests_stops_them_and_the_row_says_so(tmp_path, monkeypatch):
    module = _write_module(tmp_path, monkeypatch, "nan_after_identification", NAN_MODULE.format(after=1300, healthy=1))
    status, printed, err = run("--process", f"{module}:make", "--policies", "simc-pi", "--json")
    assert status == 0, err
    rows = json.loads(printed)["policies"]
    for row in rows:
        assert row["stopped"].startswith("set-point test: the process returned nan at t = 140 s; load test:")
        assert row["iae_setpoint"] is None and row["iae_load"] is None and row["cost"] > 20  # graded as unstable


BAD_MODULE = """
def raises():
    raise RuntimeError("the kit is not plugged in")

def nothing():
    return object()
"""


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--process", "foo"], "deadtime process: error: --process: unknown process 'foo'; give 'tclab' or module:factory"),
        (["--process", "no_such_module_here:make"], "deadtime process: error: --process: cannot import 'no_such_module_here' (ModuleNotFoundError"),
        (["--process", "{bad}:missing"], "deadtime process: error: --process: module '{bad}' has no function 'missing'"),
        (["--process", "{bad}:raises"], "deadtime process: error: --process: {bad}:raises() raised RuntimeError: the kit is not plugged in"),
        (["--process", "{bad}:nothing"], "deadtime process: error: --process: {bad}:nothing() returned no valid process: process (object) has no attribute 'name'"),
        (["--process", "tclab", "--operating-input", "120"], "deadtime process: error: operating_input 120 is outside the input limits [0, 100]"),
        (["--process", "tclab", "--setpoint-step", "60"], "deadtime process: error: setpoint_step: the closed-loop step's steady input change setpoint_step/K = 99.43 (K of the first step) from the operating input 30 gives 129.4, outside the input limits [0, 100]"),
        (["--process", "tclab", "--input-step", "-40"], "deadtime process: error: input_step: the step input_step = -40 from the operating input 30 gives -10, outside the input limits [0, 100]"),
        (["--process", "tclab", "--policies", "oracle,no-such-rule"], "deadtime process: error: unknown rule 'no-such-rule'"),
        (["--process", "tclab", "--controller", '{"type": "fppi", "model": {"gain": 1, "time_constant": 1, "dead_time": 1}, "tr": 1}'], "deadtime process: error: --controller must be a PI/PID"),
        (["--process", "{nan}:make"], "deadtime process: error: settle: the process returned nan at t = 0 s"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, monkeypatch, args, message):
    bad = _write_module(tmp_path, monkeypatch, "bad_process_factories", BAD_MODULE)
    nan = _write_module(tmp_path, monkeypatch, "nan_from_the_start", NAN_MODULE.format(after=0, healthy=-1))
    args = [a.replace("{bad}", bad).replace("{nan}", nan) for a in args]
    status, printed, err = run(*args)
    assert status == 2 and printed == ""
    assert err.count("\n") == 1 and err.startswith(message.replace("{bad}", bad).replace("{nan}", nan)), err


class _V3Agent(_Constant):
    """A fixed-mode agent of PID-v3 (measured observation, design features) playing the base rule."""

    name = "v3"
    env_id = "DeadTime/PID-v3"
    env_kwargs = {"noise_std": 0.01}


class _Selector:
    """A selector that always chooses the rule simc-pi."""

    name = "selector-x"
    env_id = "DeadTime/PID-v3"
    env_kwargs = {"noise_std": 0.01}
    seen: list = []

    def choose(self, observation):
        self.seen.append(np.array(observation))
        return "simc-pi"

    def rule_of(self, choice):
        return choice

    def action(self, choice, observation):
        raise AssertionError("a rule was chosen")


def test_a_v3_agent_and_a_selector_read_the_v3_observation_of_the_process(monkeypatch):
    import agents.evaluation.policies
    from agents.evaluation.process_policies import evaluate_policies, process_observation
    from agents.evaluation.policies import PolicySpec
    from envs.episode import LOG_CLIP, evidence_from_identification
    from dataclasses import replace

    from envs.identification.quantized_noise import quantized_noise_level
    from envs.identification.steady_state import noise_level
    from envs.process.performance import RunProtocol
    from envs.process.procedure import identify_process
    from envs.process.tclab_process import TCLabProcess

    policies = {"v3": _V3Agent(), "sel": _Selector()}
    monkeypatch.setattr(agents.evaluation.policies, "load_agent", lambda spec: (spec.name, policies[spec.name]))
    process = TCLabProcess()
    found = identify_process(process)
    _V3Agent.seen, _Selector.seen = [], []
    specs = [PolicySpec("v3", "agent", "v3"), PolicySpec("sel", "agent", "sel"), PolicySpec("simc-pi", "rule")]
    results = {r.name: r for r in evaluate_policies(process, found, RunProtocol.from_identification(found, 1.0), specs)}
    env = tuning_env_of(gym.make("DeadTime/PID-v3"))
    names = env.feature_names
    options = replace(env.options, quantization=found.quantization)  # the sensor's resolution, 0.3223 degC
    expected = env.observe(found.identification, evidence_from_identification(found.identification, options,
                                                                                abs(found.setpoint_step)))
    assert np.array_equal(_V3Agent.seen[0], expected) and np.array_equal(process_observation(env, found), expected)
    assert len(expected) == len(names) and "check_ms" in names and "failed_experiments" in names
    # measured from the record, as in simulation, knowing the sensor's resolution: the emulator's
    # quantized readings give the plain estimate 0 (the log's floor), this one the noise
    assert noise_level(found.identification.closed_loop.output) == 0.0
    sigma = quantized_noise_level(found.identification.closed_loop.output, found.quantization)
    assert sigma > 0 and expected[names.index("log_noise_ratio")] == pytest.approx(math.log10(sigma / abs(found.setpoint_step)), abs=1e-6)
    assert expected[names.index("log_noise_ratio")] > -LOG_CLIP
    assert results["v3"].parameter == pytest.approx(env.parameter_from_action(0.0)) and results["v3"].score is not None
    assert np.array_equal(_Selector.seen[0], expected)
    assert results["sel"].controller.to_dict() == results["simc-pi"].controller.to_dict()
    assert results["sel"].note.startswith("chose simc-pi") and results["sel"].role == "agent"


def test_a_process_outside_the_training_family_is_flagged_and_still_played(monkeypatch):
    import agents.evaluation.policies
    import agents.evaluation.process_policies as process_policies
    from agents.evaluation.policies import PolicySpec
    from envs.process.performance import RunProtocol
    from envs.process.procedure import identify_process
    from envs.process.tclab_process import TCLabProcess

    monkeypatch.setattr(agents.evaluation.policies, "load_agent", lambda spec: (spec.name, _V3Agent()))
    monkeypatch.setattr(process_policies, "_training_ranges", lambda env_id, kwargs: {"tau": (0.9, 0.95), "theta": (-100.0, 100.0)})
    process = TCLabProcess()
    found = identify_process(process)
    result = process_policies.evaluate_policies(process, found, RunProtocol.from_identification(found, 1.0), [PolicySpec("v3", "agent", "v3")])[1]
    assert result.score is not None and result.note.startswith("out of distribution: tau ") and "theta" not in result.note


def test_the_training_ranges_hold_the_family_and_name_only_plant_features():
    from agents.evaluation.process_policies import CHECKED_FEATURES, _training_ranges

    ranges = _training_ranges("DeadTime/FPPI-v3", {"noise_std": 0.1})
    assert set(ranges) <= set(CHECKED_FEATURES) and {"tau", "dead_time_fraction", "log_noise_ratio"} <= set(ranges)
    assert all(low < high for low, high in ranges.values())


def test_the_worked_example_of_your_own_process_runs_as_documented(tmp_path, monkeypatch):
    """docs/your_process.md: its Python block is a process the command takes, and the identification it
    prints is the page's."""
    page = (Path(__file__).resolve().parents[3] / "docs" / "your_process.md").read_text()
    code = page.split("```python\n", 1)[1].split("```", 1)[0]
    (tmp_path / "hot_water_tank_doc.py").write_text(code)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    status, printed, err = run("--process", "hot_water_tank_doc:make", "--policies", "simc-pi,fppi-ms1.8", "--no-plots")
    assert status == 0, err
    for line in printed.splitlines()[2:6]:  # the identified models: K_n, T_ar, FOPDT, SOPDT, relay
        assert line.strip() in page, line
