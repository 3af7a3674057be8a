"""Hostile and careless input to the command line: one line, exit status 2, within seconds, nothing written.

Each row of :data:`CASES` is a command (with the files it reads, written into a temporary
directory first) and a stable fragment of the one line it must print on stderr.  Every row is run
in-process through :func:`agents.cli.main` (as tests/unit/agents/test_cli_extremes.py does) and
checked for: exit status 2, exactly one line on stderr and no traceback, the fragment in it, no
line longer than :data:`MAX_LINE` (an alias bomb's value is never printed), the bound on the work
:data:`WORK_SECONDS` (CPU seconds outside numba's compiler, tests/work_time.py: a busy machine slows a row
without making it do more), and the temporary directory holding
exactly the input files afterwards (no output folder, no ``config.yaml``, no ``run.json``).  The
working directory is that temporary directory (with two files that are not text, ``binary.yaml``
and ``binary.json``), so that ``--out ""`` would show as a file written.

:data:`API_CASES` are the Python API's soft cases outside the environment classes: values it took
silently, or refused without naming the field.  Ctrl-C is one line and exit status 130.  The
limits themselves are :mod:`agents.limits` and :data:`envs.systems.plants.MAX_COEFFICIENTS`.
"""

from __future__ import annotations

import io
import json
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import NamedTuple

import pytest

from agents.cli import main
from work_time import work_seconds

ROOT = Path(__file__).resolve().parents[3]
WORK_SECONDS = 30.0
"""CPU seconds of one row outside numba's compiler.  Measured (the rows in one process): at most 1.7 s (a
``train`` row importing stable-baselines3 and torch; ``analyze --plant`` of a deep list 1.6 s), under
half a second for most; the bound is over ten times the slowest, so it only catches a refusal that does
unbounded work first."""
MAX_LINE = 2_000
"""The longest acceptable error line: a value of thousands of characters is never echoed."""

PLANT = {"num": [1], "den": [10, 1], "delay": 5}
PID = json.dumps({"type": "pid", "kp": 1.2, "ti": 9, "td": 1.5, "n": 10})
DEEP_LIST = "[" * 100_000 + "]" * 100_000
DEEP_OBJECT = '{"a":' * 100_000 + "1" + "}" * 100_000


def _bomb(levels: int = 9) -> str:
    """A flow YAML "billion laughs": ``levels`` anchors, each a list of nine aliases of the one before (9**levels)."""
    items = ["&l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    items += [f"&l{k} [{', '.join([f'*l{k - 1}'] * 9)}]" for k in range(1, levels)]
    return "[" + ", ".join(items) + "]"


BOMB = _bomb()
DEEP_YAML = "[" * 5_000 + "]" * 5_000
EVALUATE = ["evaluate", "--env", "DeadTime/PID-v0", "--policies", "simc-pi", "--n", "2", "--no-benchmark", "--no-plots"]
PPO = str(ROOT / "configs" / "ppo.yaml")
SAC = str(ROOT / "configs" / "sac.yaml")


def _plant(den_size: int) -> str:
    return json.dumps({"num": [1.0], "den": [1.0] * den_size, "delay": 1.0})


def _zoo(top: str) -> str:
    """A training config whose ``default`` entry is valid, with ``top`` added at the top of the file."""
    return ("default:\n  algorithm: PPO\n  env_id: DeadTime/PID-v0\n  total_timesteps: 100\n"
            "  hyperparameters: {n_steps: 16, batch_size: 16}\n" + top)


def _sweep(trials: str, extra: str = "") -> str:
    return f"{extra}trials:\n  - config: {PPO}\n    envs: [DeadTime/PID-v0]\n    {trials}\n"


class Case(NamedTuple):
    argv: list[str]
    fragment: str
    files: dict[str, str] = {}


CASES: dict[str, Case] = {
    # nesting: RecursionError in the JSON decoder or in PyYAML's composer
    "analyze --plant deep": Case(["analyze", "--plant", DEEP_LIST, "--controller", PID], "--plant nests deeper than 32 levels"),
    "analyze --controller deep": Case(["analyze", "--plant", json.dumps(PLANT), "--controller", DEEP_OBJECT],
                                      "--controller nests deeper than 32 levels"),
    "tune --model deep": Case(["tune", "--rule", "simc-pi", "--model", DEEP_LIST], "--model nests deeper than 32 levels"),
    "evaluate --plants deep": Case([*EVALUATE, "--plants", DEEP_LIST, "--out", "out"], "--plants nests deeper than 32 levels"),
    "evaluate --env-kwargs deep": Case([*EVALUATE, "--env-kwargs", DEEP_OBJECT, "--out", "out"],
                                       "--env-kwargs nests deeper than 32 levels"),
    "process --controller deep": Case(["process", "--process", "tclab", "--controller", DEEP_LIST],
                                      "--controller nests deeper than 32 levels"),
    "train deep YAML file": Case(["train", "--config", "deep.yaml", "--out", "run"], "deep.yaml nests deeper than 32 levels",
                                 {"deep.yaml": _zoo(f"DeadTime/PID-v0: {{env_kwargs: {{x: {DEEP_YAML}}}}}\n")}),
    "train deep override": Case(["train", "--config", PPO, "--out", "run", f"env_kwargs.x={DEEP_YAML}"],
                                "override 'env_kwargs.x' nests deeper than 32 levels"),
    "integer of 10000 digits": Case(["analyze", "--plant", '{"num": [' + "1" * 10_000 + '], "den": [1, 1], "delay": 1}',
                                     "--controller", PID], "--plant is not valid JSON"),
    "train binary config": Case(["train", "--config", "binary.yaml", "--out", "run"], "binary.yaml is not a text file"),
    "analyze binary plant file": Case(["analyze", "--plant", "binary.json", "--controller", PID], "binary.json is not a text file"),
    # alias bombs: refused before they are expanded, never printed
    "train bomb as a value": Case(["train", "--config", "bomb.yaml", "--out", "run"], "bomb.yaml holds more than 100000 values",
                                  {"bomb.yaml": _zoo(f"DeadTime/PID-v0: {{env_kwargs: {{x: {BOMB}}}}}\n")}),
    "train bomb merged from default": Case(
        ["train", "--config", "merged.yaml", "--out", "run"], "merged.yaml holds more than 100000 values",
        {"merged.yaml": f"default: &d\n  algorithm: PPO\n  env_id: DeadTime/PID-v0\n  total_timesteps: 100\n"
                        f"  env_kwargs: {{x: {BOMB}}}\nDeadTime/PID-v0:\n  <<: *d\n"}),
    "train bomb in an override": Case(["train", "--config", PPO, "--out", "run", f"env_kwargs.x={BOMB}"],
                                      "override 'env_kwargs.x' holds more than 100000 values"),
    "sweep bomb in env_kwargs": Case(["sweep", "--config", "bomb.yaml", "--out", "sweep"], "bomb.yaml holds more than 100000 values",
                                     {"bomb.yaml": _sweep("seeds: [0]", f"env_kwargs: {{x: {BOMB}}}\n")}),
    # evaluate: validated before --out is created
    "evaluate --seed -1": Case([*EVALUATE, "--seed", "-1", "--out", "out"], "--seed must be an integer >= 0, got -1"),
    "evaluate render_mode human": Case([*EVALUATE, "--env-kwargs", '{"render_mode": "human"}', "--out", "out"],
                                       "render_mode: DeadTime/PID-v0 renders 'rgb_array', got 'human'"),
    "evaluate --out empty": Case([*EVALUATE, "--out", ""], "--out must name a directory, got the empty string"),
    "evaluate --resamples 1e12": Case([*EVALUATE, "--resamples", str(10**12), "--out", "out"], "--resamples must be at most 100000"),
    "evaluate --n 1e12": Case([*EVALUATE, "--n", str(10**12), "--out", "out"], "--n must be at most 10000"),
    "evaluate --n 1e12 as typed": Case([*EVALUATE, "--n", "1e12", "--out", "out"], "argument --n: invalid int value: '1e12'"),
    "evaluate --workers 1e6": Case([*EVALUATE, "--workers", str(10**6), "--out", "out"], "--workers must be at most 64"),
    "evaluate max_episode_steps -1": Case([*EVALUATE, "--env-kwargs", '{"max_episode_steps": -1}', "--out", "out"],
                                          "max_episode_steps must be null or an integer >= 1, got -1"),
    "evaluate a regime no episode survives": Case([*EVALUATE, "--env-kwargs", '{"noise_std": 1e300}', "--out", "out"],
                                                  "identified no usable model"),
    "evaluate --plants 6000 coefficients": Case([*EVALUATE, "--plants", f"[{_plant(6_000)}]", "--out", "out"],
                                                "plant.den must have at most 101 coefficients"),
    # plants
    "analyze 6000 coefficients": Case(["analyze", "--plant", _plant(6_000), "--controller", PID],
                                      "plant.den must have at most 101 coefficients (the documented limit, envs.systems.plants.MAX_COEFFICIENTS), got 6000"),
    "analyze a million coefficients": Case(["analyze", "--plant", _plant(1_000_000), "--controller", PID],
                                           "plant.den must have at most 101 coefficients"),
    "tune 6000 coefficients": Case(["tune", "--rule", "simc-pi", "--plant", _plant(6_000)], "plant.den must have at most 101"),
    # training configs: refused before config.yaml and run.json are written
    "train buffer_size 1e14": Case(["train", "--config", SAC, "--out", "run", f"hyperparameters.buffer_size={10**14}"],
                                   "hyperparameters.buffer_size must be at most 10000000"),
    "train n_steps 1e9": Case(["train", "--config", PPO, "--out", "run", f"hyperparameters.n_steps={10**9}"],
                              "hyperparameters.n_steps * n_envs must be at most 10000000"),
    "train net_arch [100000, 100000]": Case(["train", "--config", PPO, "--out", "run", "policy_kwargs.net_arch=[100000, 100000]"],
                                            "a layer of policy_kwargs.net_arch must be at most 1024"),
    "train net_arch 100 layers": Case(["train", "--config", PPO, "--out", "run", f"policy_kwargs.net_arch={[8] * 100}"],
                                      "the number of hidden layers of policy_kwargs.net_arch must be at most 8"),
    "train invalid device": Case(["train", "--config", PPO, "--out", "run", "device=banana:7"],
                                 "device must be auto or a torch device"),
    "train family_config=5": Case(["train", "--config", PPO, "--out", "run", "env_kwargs.family_config=5"],
                                  "env_kwargs: refused by DeadTime/PID-v0"),
    "train learned rule family_config=5": Case(["train", "--config", str(ROOT / "configs" / "learned_rule.yaml"), "--out", "run",
                                                "env_kwargs.family_config=5"], "env_kwargs: refused by DeadTime/PID-v0"),
    "train n_envs 100000": Case(["train", "--config", PPO, "--out", "run", "n_envs=100000"], "n_envs must be at most 256"),
    "train n_eval_episodes 1e8": Case(["train", "--config", PPO, "--out", "run", "n_eval_episodes=1e8"],
                                      "n_eval_episodes must be at most 10000"),
    "train total_timestep at the top": Case(["train", "--config", "typo.yaml", "--out", "run"],
                                            "unknown config key 'total_timestep' at the top of typo.yaml (did you mean "
                                            "'total_timesteps', under 'default'?)", {"typo.yaml": _zoo("total_timestep: 5\n")}),
    "train misspelled env id section": Case(["train", "--config", "typo.yaml", "--out", "run"],
                                            "unknown config key 'DeadTime/PDI-v0' at the top of typo.yaml (did you mean "
                                            "'DeadTime/PID-v0'?)", {"typo.yaml": _zoo("DeadTime/PDI-v0: {total_timesteps: 5}\n")}),
    "train misspelled key of a run's config": Case(["train", "--config", "config.yaml", "--out", "run"],
                                                   "unknown config key 'total_timestep' in config.yaml (did you mean "
                                                   "'total_timesteps'?)",
                                                   {"config.yaml": "algorithm: PPO\nenv_id: DeadTime/PID-v0\ntotal_timestep: 5\n"}),
    # sweeps
    "sweep seeds count 1e8": Case(["sweep", "--config", "big.yaml", "--out", "sweep"], "trials[0].seeds.count must be at most 1000",
                                  {"big.yaml": _sweep("seeds: {count: 100000000}")}),
    "sweep env_kwargs a trial's environment refuses": Case(
        ["sweep", "--config", "bad.yaml", "--out", "sweep"],
        "trial bad-PID-v0-s0: env_kwargs: refused by DeadTime/PID-v0: noise_std must be >= 0, got -1.0",
        {"bad.yaml": _sweep("seeds: [0]\n    label: bad\n    overrides: [env_kwargs.noise_std=-1]")}),
    "sweep evaluation.n 1e12": Case(["sweep", "--config", "big.yaml", "--out", "sweep"], "evaluation.n must be at most 10000",
                                    {"big.yaml": _sweep("seeds: [0]", f"evaluation: {{n: {10**12}}}\n")}),
    "evaluate misspelled rule": Case(["evaluate", "--env", "DeadTime/PID-v0", "--policies", "simc-ip", "--out", "out"],
                                     "unknown rule 'simc-ip' (did you mean 'simc-pi'?)"),
    # process
    "process --load-step 200": Case(["process", "--process", "tclab", "--load-step", "200"],
                                    "--load-step 200 is outside the load input's range [0, 100]"),
    "process --load-step 1e300": Case(["process", "--process", "tclab", "--load-step", "1e300"],
                                      "--load-step 1e+300 is outside the load input's range [0, 100]"),
    "process --seed -1": Case(["process", "--process", "tclab", "--seed", "-1"], "--seed must be an integer >= 0, got -1"),
    "process --out empty": Case(["process", "--process", "tclab", "--out", ""], "--out must name a directory"),
    "sweep --out empty": Case(["sweep", "--config", "ok.yaml", "--out", ""], "--out must name a directory",
                              {"ok.yaml": _sweep("seeds: [0]")}),
    "regimes --out empty": Case(["regimes", "a", "b", "--x", "noise_std", "--out", ""], "--out must name a directory"),
    "regimes --resamples 1e12": Case(["regimes", "a", "b", "--x", "noise_std", "--resamples", str(10**12), "--out", "out"],
                                     "--resamples must be at most 100000"),
}


def _files(directory: Path) -> set[str]:
    return {str(path.relative_to(directory)) for path in directory.rglob("*")}


@pytest.mark.parametrize("name", list(CASES))
def test_hostile_input_is_one_line_exit_2_and_nothing_written(name: str, tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    case = CASES[name]
    for file_name, text in case.files.items():
        (tmp_path / file_name).write_text(text)
    for binary in ("binary.yaml", "binary.json"):
        (tmp_path / binary).write_bytes(bytes(range(128, 256)))
    monkeypatch.chdir(tmp_path)
    before = _files(tmp_path)
    out, err = io.StringIO(), io.StringIO()
    with work_seconds() as work, redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(case.argv)
        except SystemExit as exit_:
            code = exit_.code
    lines = err.getvalue().strip().splitlines()
    assert code == 2, (code, err.getvalue()[-2000:])
    assert len(lines) == 1 and "Traceback" not in lines[0], lines
    assert case.fragment in lines[0], lines[0][:MAX_LINE]
    assert len(lines[0]) < MAX_LINE, lines[0][:MAX_LINE]
    assert work.seconds < WORK_SECONDS, work.seconds
    assert _files(tmp_path) == before


# ----------------------------------------------------------------------------------- the Python API
API_CASES = {
    "Plant boolean coefficient": ("envs.systems.plants:Plant", {"num": [True], "den": [10.0, 1.0], "dead_time": 1.0},
                                  "num must be a list of numbers, got [True]"),
    "Plant string coefficient": ("envs.systems.plants:Plant", {"num": ["1"], "den": [10.0, 1.0], "dead_time": 1.0},
                                 "num must be a list of numbers, got ['1']"),
    "Plant boolean dead time": ("envs.systems.plants:Plant", {"num": [1.0], "den": [10.0, 1.0], "dead_time": True},
                                "dead_time must be a number, got True"),
    "Plant string dead time": ("envs.systems.plants:Plant", {"num": [1.0], "den": [10.0, 1.0], "dead_time": "5"},
                               "dead_time must be a number, got '5'"),
    "Plant 6000 coefficients": ("envs.systems.plants:Plant", {"num": [1.0], "den": [1.0] * 6000, "dead_time": 1.0},
                                "den must have at most 101 coefficients"),
    "sample_plants n=True": ("envs.systems.families:sample_plants", {"family": "fopdt", "n": True, "seed": 0},
                             "n must be an integer >= 0, got True"),
    "sample_plants n=2.5": ("envs.systems.families:sample_plants", {"family": "fopdt", "n": 2.5, "seed": 0},
                            "n must be an integer >= 0, got 2.5"),
    "sample_plants seed=True": ("envs.systems.families:sample_plants", {"family": "fopdt", "n": 2, "seed": True},
                                "seed must be an integer >= 0, got True"),
    "check_family_config 5": ("envs.systems.families:check_family_config", {"family": "stable", "config": 5},
                              "family_config must be a MixtureConfig for family 'stable', got int"),
    "require_real_array bool": ("envs.validation:require_real_array", {"value": True, "name": "action"},
                                "action must be real numbers, got bool"),
    "require_real_array complex": ("envs.validation:require_real_array", {"value": [0.5 + 2j], "name": "action"},
                                   "action must be real numbers, got complex128"),
    "require_real_array text": ("envs.validation:require_real_array", {"value": ["0.5"], "name": "action"},
                                "action must be real numbers, got text"),
    "analyze a wrong controller": ("envs.analysis.loop_analysis:analyze", {"plant": PLANT, "controller": 5},
                                   "controller must be a PID, SeriesPID, FPPI or MSP"),
    "evaluate seed=True": ("agents.evaluation.evaluate:evaluate", {"env_id": "DeadTime/PID-v0", "policies": "simc-pi", "n": 2,
                                                                  "seed": True, "out": Path("out")}, "--seed must be an integer"),
    "evaluate n=2.5": ("agents.evaluation.evaluate:evaluate", {"env_id": "DeadTime/PID-v0", "policies": "simc-pi", "n": 2.5,
                                                              "seed": 0, "out": Path("out")}, "--n must be an integer >= 1, got 2.5"),
    "evaluate out=''": ("agents.evaluation.evaluate:evaluate", {"env_id": "DeadTime/PID-v0", "policies": "simc-pi", "n": 2,
                                                               "seed": 0, "out": ""}, "out must name a directory"),
}


@pytest.mark.parametrize("name", list(API_CASES))
def test_python_api_names_the_field(name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Values the Python API accepted silently (or refused without naming the field): a ``ValueError`` naming it."""
    from importlib import import_module

    target, kwargs, fragment = API_CASES[name]
    module, function = target.split(":")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError) as error:
        getattr(import_module(module), function)(**kwargs)
    assert fragment in str(error.value)
    assert not any(tmp_path.iterdir())


def test_help_texts_quote_the_plant_limit() -> None:
    """The help texts quote :data:`agents.commands.arguments.PLANT_COEFFICIENTS` (parsing loads no envs numerics)."""
    from agents.commands.arguments import PLANT_COEFFICIENTS
    from envs.systems.plants import MAX_COEFFICIENTS

    assert PLANT_COEFFICIENTS == MAX_COEFFICIENTS


def test_ctrl_c_is_one_line_and_exit_130(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """Ctrl-C in a subcommand that does not handle it itself: one line, exit status 130, no traceback."""
    import agents.commands.analyze

    def interrupted(args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(agents.commands.analyze, "run", interrupted)
    assert main(["analyze", "--plant", json.dumps(PLANT), "--controller", PID]) == 130
    assert capsys.readouterr().err.strip().splitlines() == ["deadtime analyze: interrupted"]
