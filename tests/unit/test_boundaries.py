"""One direction of dependency (STYLE.md, Boundaries).

The physics core of ``envs`` (plants, simulation, controllers, loops, robustness, performance,
analysis) is importable without torch or stable-baselines3; inside ``envs`` only
``envs/__init__.py`` (registration) and one module holding the ``gymnasium.Env`` classes may import
gymnasium, and no module imports torch or stable-baselines3.  Importing any ``envs`` module runs
``envs/__init__.py`` and so loads gymnasium: that is the registration on ``import envs`` that SPEC
asks for (and STYLE's "``envs/__init__.py`` holds the ``register(...)`` calls"); the numerical
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
    "envs.analysis.compiled_robustness",
    "envs.analysis.compiled_iae",
    "envs.analysis.scoring",
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
    """Top-level names of every import in the module, including those inside functions."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def _defines_env_class(path: Path) -> bool:
    """True if the module defines a class deriving from ``Env`` / ``gymnasium.Env`` / ``gym.Env``."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ClassDef):
            for base in node.bases:
                name = base.attr if isinstance(base, ast.Attribute) else getattr(base, "id", "")
                if name == "Env":
                    return True
    return False


ENV_MODULES = sorted((REPO / "envs").rglob("*.py"))


@pytest.mark.parametrize("path", ENV_MODULES, ids=lambda p: str(p.relative_to(REPO)))
def test_no_envs_module_imports_learning_packages(path):
    assert not _imported_packages(path) & {"torch", "stable_baselines3"}


def test_only_registration_and_one_env_class_module_import_gymnasium():
    importers = [p for p in ENV_MODULES if "gymnasium" in _imported_packages(p)]
    others = [p for p in importers if p != REPO / "envs" / "__init__.py"]
    assert len(others) <= 1, f"gymnasium imported by {[str(p.relative_to(REPO)) for p in others]}"
    for path in others:
        assert _defines_env_class(path), f"{path.relative_to(REPO)} imports gymnasium but defines no Env class"
