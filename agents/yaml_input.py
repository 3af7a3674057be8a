"""YAML read within bounds: ``yaml.safe_load`` with the nesting and the expanded size limited.

Every YAML that ``deadtime`` reads (training configs, sweep files, ``key=value`` overrides, a run's
``config.yaml``) goes through :func:`load_yaml`.  It builds the values as ``yaml.safe_load`` does (no
tag ever executes code) after two checks on the composed document, before any value is constructed:

* nesting deeper than :data:`agents.limits.MAX_NESTING` is refused as it is read (PyYAML composes
  recursively, so a deeper document would otherwise end in a ``RecursionError``);
* more than :data:`agents.limits.MAX_YAML_NODES` values with the aliases expanded is refused.  PyYAML
  shares one object among the uses of an alias, so an alias bomb loads in microseconds but expands
  to billions of values in whatever walks it (a merge, a copy, a printed message, ``yaml.safe_dump``).
  The count is memoized per node, so it takes time linear in the document's text.

A refusal is a ``ValueError`` that names the source and never prints the value.  Files are read as
UTF-8 text (:func:`read_text`, also for the JSON arguments that name a file); a binary file is
refused by name.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from agents.limits import MAX_NESTING, MAX_YAML_NODES

__all__ = ["load_yaml", "load_yaml_file", "read_text"]


class _Refused(Exception):
    """A document beyond the limits (raised inside the loader, reported by :func:`load_yaml`)."""


class _BoundedLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that stops composing at :data:`MAX_NESTING` levels."""

    depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self.depth += 1
        try:
            if self.depth > MAX_NESTING:
                raise _Refused(f"nests deeper than {MAX_NESTING} levels (agents/limits.py)")
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


def _expanded_size(node: yaml.Node, sizes: dict[int, int]) -> int:
    """Values under ``node`` (itself included) with every alias expanded; ``sizes`` memoizes per node."""
    known = sizes.get(id(node))
    if known is not None:
        return known
    size = 1
    if isinstance(node, yaml.SequenceNode):
        size += sum(_expanded_size(child, sizes) for child in node.value)
    elif isinstance(node, yaml.MappingNode):
        size += sum(_expanded_size(key, sizes) + _expanded_size(value, sizes) for key, value in node.value)
    sizes[id(node)] = size
    return size


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split())


def read_text(path: Path) -> str:
    """The text of ``path``; a file that is not UTF-8 text is a ``ValueError`` naming it."""
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(f"{path} is not a text file (not UTF-8 at byte {error.start})") from None


def load_yaml_file(path: str | Path) -> Any:
    """:func:`load_yaml` of the file ``path``, named in every message."""
    path = Path(path)
    return load_yaml(read_text(path), str(path))


def load_yaml(text: str, where: str) -> Any:
    """The value of the YAML ``text`` (as ``yaml.safe_load``), read within the limits.

    Parameters
    ----------
    text : str
        The document.
    where : str
        What it is, for the message (a path, ``override 'x=...'``).

    Raises
    ------
    ValueError
        ``"<where> is not valid YAML: ..."`` (on one line), or ``"<where> nests deeper than 32
        levels ..."`` / ``"<where> holds more than 100000 values ..."`` for a document beyond the
        limits (the value itself is never printed).
    """
    loader = _BoundedLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        size = _expanded_size(node, {})
        if size > MAX_YAML_NODES:
            raise _Refused(f"holds more than {MAX_YAML_NODES} values with its aliases expanded (agents/limits.py; "
                           "an alias repeated inside aliases multiplies them)")
        return loader.construct_document(node)
    except _Refused as error:
        raise ValueError(f"{where} {error}") from None
    except (yaml.YAMLError, ValueError, RecursionError) as error:  # ValueError: e.g. an integer of 5000 digits
        raise ValueError(f"{where} is not valid YAML: {_one_line(error)}") from None
    finally:
        loader.dispose()
