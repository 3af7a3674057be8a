"""The controller structures are asked, not named: :mod:`envs.structures` is the one place that knows them.

An AST count of the comparisons of a structure's name as a string (``structure == "msp"``,
``kind in ("pid", "fppi")``) in the package outside :mod:`envs.structures`; what is left compares
controller types of JSON and of the paper reproductions, which share the names.  And the map from a
structure to the model its design reads is written once, as :attr:`envs.structures.Structure.model`.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from envs.structures import STRUCTURES, design, relative_scale, structure

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("envs", "baselines", "agents")
MAX_NAME_COMPARISONS = 10
MODEL_FIELDS = {"sopdt", "fopdt", "integrating_model"}


def _modules():
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if path.relative_to(ROOT).as_posix() != "envs/structures.py":
                yield path, ast.parse(path.read_text(encoding="utf-8"))


def _strings(node: ast.AST) -> list[str]:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return [e.value for e in node.elts if isinstance(e, ast.Constant) and isinstance(e.value, str)]
    return []


def _name_comparisons() -> list[str]:
    found = []
    for path, tree in _modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.Compare) and any(
                name in STRUCTURES for side in (node.left, *node.comparators) for name in _strings(side)
            ):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    return found


def test_structure_names_are_compared_at_most_ten_times():
    found = _name_comparisons()
    assert len(found) <= MAX_NAME_COMPARISONS, "\n".join(found)


def test_the_model_map_is_written_once():
    """No mapping from structure names to the identified models outside :mod:`envs.structures`."""
    maps = []
    for path, tree in _modules():
        for node in ast.walk(tree):
            if not isinstance(node, ast.Dict):
                continue
            keys = [k.value for k in node.keys if isinstance(k, ast.Constant) and isinstance(k.value, str)]
            values = {v.attr for v in node.values if isinstance(v, ast.Attribute)}
            if sum(k in STRUCTURES for k in keys) >= 2 and values & MODEL_FIELDS:
                maps.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not maps


@pytest.mark.parametrize("name", list(STRUCTURES))
def test_registry_entries_are_consistent(name):
    s = structure(name)
    low, high = s.parameter_range
    assert s.name == name and 0 < low < high
    assert s.model in MODEL_FIELDS
    assert s.integrating == (s.model == "integrating_model") == (s.family == "integrating")
    assert s.design_experiments[0] == "closed-loop-step"


def test_unknown_structure_is_one_clear_error():
    with pytest.raises(ValueError, match=r"unknown structure 'pd'; valid: pid, fppi, msp, pi"):
        structure("pd")


def test_module_functions_are_the_structures():
    from envs.identification.models import FOPDTModel

    model = FOPDTModel(2.0, 3.0, 0.5)
    assert relative_scale("fppi", model) == 3.0
    assert design("fppi", model, 1.5) == STRUCTURES["fppi"].relative_design(model, 0.5)
