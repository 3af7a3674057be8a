"""One direction of dependency (docs/architecture.md).

``envs`` -> ``baselines`` -> ``agents``: no module under ``envs/`` imports ``baselines`` or
``agents``, and none under ``baselines/`` imports ``agents`` (every import statement counts, the
lazy ones inside functions too, and ``importlib.import_module("...")`` with a literal name; read
from the source with :mod:`ast`, so no import has to run).  torch, stable-baselines3 and Ray are
imported under ``agents/`` only, and ``baselines`` never imports gymnasium.

The physics core of ``envs`` (plants, simulation, controllers, loops, robustness, performance,
analysis) and the baselines are importable without torch or stable-baselines3 (checked in a fresh
interpreter); inside ``envs`` only ``envs/__init__.py`` (registration), one module holding the
``gymnasium.Env`` classes and its sibling holding their native ``VectorEnv`` classes (a vector
environment lives beside its single environment) may import gymnasium.  Importing any ``envs`` module runs
``envs/__init__.py`` and so loads gymnasium: that is the registration on ``import envs`` that makes the ids
known to ``gymnasium.make`` (``envs/__init__.py`` holds the ``register(...)`` calls); the numerical
modules themselves never import it (checked statically below).
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CORE = [
    "envs.systems.plants",
    "envs.simulation.delay_systems",
    "envs.systems.controllers",
    "envs.simulation.loops",
    "envs.analysis.robustness",
    "envs.analysis.performance",
    "envs.analysis.loop_analysis",
    "envs.analysis.loop_transfer",
    "envs.analysis._robustness_kernels",
    "envs.analysis._iae_kernels",
    "envs.analysis.scoring",
    "envs.process.procedure",
    "envs.process.scoring",
    "envs.process.tclab_process",
    "baselines.rules.registry",
    "baselines.rules.tune",
    "baselines.oracle",
    "baselines.process_oracle",
]
HEAVY = ("torch", "stable_baselines3", "gymnasium")


@pytest.fixture(scope="module")
def loaded_after_core_import() -> dict[str, bool]:
    """Which heavy packages a fresh interpreter holds after importing the core modules."""
    code = (
        "import importlib, json, sys\n"
        f"for name in {CORE!r}:\n"
        "    importlib.import_module(name)\n"
        f"print(json.dumps({{m: m in sys.modules for m in {HEAVY!r}}}))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=REPO, timeout=120)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("package", ["torch", "stable_baselines3"])
def test_core_does_not_load_learning_packages(loaded_after_core_import, package):
    assert not loaded_after_core_import[package]


def _imported_packages(path: Path) -> set[str]:
    """Top-level names of every import in the module, including those inside functions, and of
    ``importlib.import_module``/``__import__`` calls with a literal name."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
            function = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
            if function in ("import_module", "__import__") and isinstance(node.args[0].value, str):
                names.add(node.args[0].value.split(".")[0])
    return names


def _defines_env_class(path: Path) -> bool:
    """True if the module defines a class deriving from ``Env`` / ``gymnasium.Env`` / ``gym.Env``, or ``VectorEnv``."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ClassDef):
            for base in node.bases:
                name = base.attr if isinstance(base, ast.Attribute) else getattr(base, "id", "")
                if name in ("Env", "VectorEnv"):
                    return True
    return False


ENV_MODULES = sorted((REPO / "envs").rglob("*.py"))
BASELINE_MODULES = sorted((REPO / "baselines").rglob("*.py"))
LEARNING = {"torch", "stable_baselines3", "ray"}
# What each package may not import: the layers below it never import the layers above.
FORBIDDEN = {"envs": {"baselines", "agents"} | LEARNING, "baselines": {"agents", "gymnasium"} | LEARNING}


def _relative(path: Path) -> str:
    return str(path.relative_to(REPO))


@pytest.mark.parametrize("path", ENV_MODULES + BASELINE_MODULES, ids=_relative)
def test_no_module_imports_a_layer_above_it_or_learning_packages(path):
    package = path.relative_to(REPO).parts[0]
    assert sorted(_imported_packages(path) & FORBIDDEN[package]) == []


def test_the_scan_finds_a_lazy_import(tmp_path):
    """The check itself: an import inside a function, and a literal ``import_module``, are found."""
    module = tmp_path / "module.py"
    module.write_text("def f():\n    from baselines.oracle import oracle\n\n"
                      "def g():\n    import importlib\n    importlib.import_module('torch.nn')\n")
    assert _imported_packages(module) == {"baselines", "importlib", "torch"}


def test_only_registration_and_the_env_class_modules_import_gymnasium():
    importers = [p for p in ENV_MODULES if "gymnasium" in _imported_packages(p)]
    others = [p for p in importers if p != REPO / "envs" / "__init__.py"]
    assert len(others) <= 2, f"gymnasium imported by {[str(p.relative_to(REPO)) for p in others]}"
    for path in others:
        assert _defines_env_class(path), f"{path.relative_to(REPO)} imports gymnasium but defines no Env class"
