"""The one reader of the files ``deadtime`` reads: YAML, JSON, JSON lines and CSV, within bounds.

Every file the package reads back (configs, sweep files, a run's ``config.yaml``, ``run.json``,
checkpoint manifests, ``sessions.json``, the learned rule's label cache, the evaluation cache,
``results.json`` and ``per_plant.csv``) goes through this module, so that every problem is one line
naming the file, a :class:`FileProblem` (a ``ValueError``: the command line prints it and exits with
status 2):

* a file larger than :data:`agents.limits.MAX_FILE_BYTES`, one that cannot be read, or one that is
  not UTF-8 text;
* nesting deeper than :data:`agents.limits.MAX_NESTING` (checked before Python's recursion limit is
  reached) and, in YAML, more than :data:`agents.limits.MAX_YAML_NODES` values with the aliases
  expanded (an alias bomb);
* a key given twice in one mapping (YAML and JSON parsers otherwise keep the last silently);
* a control character in a YAML file, any parse error, a CSV row cut short (a file whose last line
  has no line end, as a kill while writing leaves it), a field longer than
  :data:`agents.limits.MAX_CSV_FIELD`, a missing column, an empty or header-only table;
* a value of another type than the caller requires (``kind``).

A file stored gzip-compressed (``NAME.gz``, :mod:`agents.compressed`) is read by its plain name.

YAML is built as ``yaml.safe_load`` builds it (no tag executes code), with one difference: numbers
written as researchers write them, ``1e-3`` or ``3E4`` (no decimal point, which YAML 1.1 requires),
are read as floats, as YAML 1.2 and JSON read them.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import re
import zlib
from pathlib import Path
from typing import Any

import yaml

from agents.limits import MAX_CSV_FIELD, MAX_FILE_BYTES, MAX_NESTING, MAX_YAML_NODES

__all__ = ["DamagedFileError", "FileProblem", "MissingFile", "damaged", "exists", "load_yaml", "load_yaml_file", "parse_json", "read_csv",
           "read_json", "read_record", "read_text", "stored_path"]


class FileProblem(ValueError):
    """A file that cannot be read, or does not hold what it must; the message is one line naming it."""


class MissingFile(FileProblem, FileNotFoundError):
    """A file that is not there (also a ``FileNotFoundError``, for callers that ask for one)."""


class DamagedFileError(FileProblem):
    """A file of a run that is missing, truncated, unreadable or altered; the message names it."""


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split())


# ------------------------------------------------------------------------------------- text
def stored_path(path: str | Path) -> Path:
    """``path`` if it exists, else ``path`` + ``.gz`` if that exists, else ``path`` (so that an error names it).

    A committed sweep keeps its bulky tables and records gzip-compressed (:mod:`agents.compressed`);
    every reader here reads them by their plain name."""
    path = Path(path)
    if path.exists() or path.suffix == ".gz":
        return path
    compressed = path.with_name(path.name + ".gz")
    return compressed if compressed.exists() else path


def exists(path: str | Path) -> bool:
    """Whether ``path`` or its ``.gz`` is a file."""
    return stored_path(path).is_file()


def read_text(path: str | Path, limit: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text of ``path`` (or of ``path.gz``, decompressed), at most ``limit`` bytes.

    Raises
    ------
    FileProblem
        If the file cannot be read, is larger than ``limit`` (decompressed) or is not UTF-8 text, naming it.
    """
    path = stored_path(path)
    try:
        with (gzip.open(path, "rb") if path.suffix == ".gz" else open(path, "rb")) as handle:
            data = handle.read(limit + 1)
    except FileNotFoundError as error:
        raise MissingFile(f"{path} cannot be read ({error.strerror or error})") from None
    except OSError as error:  # gzip.BadGzipFile too
        raise FileProblem(f"{path} cannot be read ({error.strerror or error})") from None
    except (EOFError, zlib.error) as error:
        raise FileProblem(f"{path} cannot be read (a damaged compressed file: {error})") from None
    if len(data) > limit:
        raise FileProblem(f"{path} is larger than {limit} bytes (agents/limits.py MAX_FILE_BYTES)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise FileProblem(f"{path} is not a text file (not UTF-8 at byte {error.start})") from None


def _require_kind(value: Any, kind: type | tuple[type, ...] | None, where: str) -> Any:
    if kind is not None and not isinstance(value, kind):
        names = " or ".join(_KIND_NAMES.get(k, k.__name__) for k in (kind if isinstance(kind, tuple) else (kind,)))
        raise FileProblem(f"{where} must hold {names}, got {_KIND_NAMES.get(type(value), type(value).__name__)}")
    return value


_KIND_NAMES = {dict: "a mapping (object)", list: "a list (array)", str: "a string", int: "an integer",
               float: "a number", type(None): "nothing"}


# ------------------------------------------------------------------------------------- JSON
class _Duplicate(Exception):
    pass


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    mapping: dict[str, Any] = {}
    for key, value in pairs:
        if key in mapping:
            raise _Duplicate(key)
        mapping[key] = value
    return mapping


def _depth(value: Any) -> int:
    """Levels of lists and mappings in a decoded value (a scalar is 0), counted without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, level = stack.pop()
        children = item.values() if isinstance(item, dict) else item if isinstance(item, list) else None
        if children is not None:
            deepest = max(deepest, level)
            if level <= MAX_NESTING:
                stack.extend((child, level + 1) for child in children)
    return deepest


def parse_json(text: str, where: str, kind: type | tuple[type, ...] | None = None) -> Any:
    """The value of the JSON ``text``, with duplicate keys and nesting beyond the limit refused.

    Raises
    ------
    FileProblem
        ``"<where> is not valid JSON: ..."``, ``"<where> nests deeper than 32 levels ..."``,
        ``"<where> holds the key 'k' twice ..."``, or ``"<where> must hold ..."`` (``kind``).
    """
    try:
        value = json.loads(text, object_pairs_hook=_unique_pairs)
    except _Duplicate as error:
        raise FileProblem(f"{where} holds the key {error.args[0]!r} twice in one object") from None
    except RecursionError:
        raise FileProblem(f"{where} nests deeper than {MAX_NESTING} levels (agents/limits.py)") from None
    except json.JSONDecodeError as error:
        raise FileProblem(f"{where} is not valid JSON ({error.msg} at line {error.lineno} column {error.colno})") from None
    except ValueError as error:  # e.g. an integer of more digits than Python converts
        raise FileProblem(f"{where} is not valid JSON ({_one_line(error)})") from None
    if _depth(value) > MAX_NESTING:
        raise FileProblem(f"{where} nests deeper than {MAX_NESTING} levels (agents/limits.py)")
    return _require_kind(value, kind, where)


def read_json(path: str | Path, kind: type | tuple[type, ...] | None = None) -> Any:
    """:func:`parse_json` of the file ``path``, named in every message."""
    return parse_json(read_text(path), str(path), kind)


def damaged(error: FileProblem, path: str | Path, advice: str = "") -> DamagedFileError:
    """``error`` about ``path`` as a :class:`DamagedFileError`: ``"<path> is damaged: <what is wrong>[; advice]"``."""
    text, name = str(error), str(path)
    reason = text[len(name):].strip() if text.startswith(name) else text
    reason = reason[3:] if reason.startswith("is ") else reason
    return DamagedFileError(f"{name} is damaged: {reason}{f'; {advice}' if advice else ''}")


def read_record(path: str | Path, kind: type[dict] | type[list]) -> Any:
    """The JSON object (``kind`` dict) or array (``kind`` list) of a run's record, or None if there is no file.

    Raises
    ------
    DamagedFileError
        If the file cannot be read, is not valid JSON or not of ``kind``, naming it and what to do.
    """
    path = Path(path)
    if not path.exists():
        return None
    advice = "restore it, or move it away to start its record afresh"
    try:
        data = read_json(path)
    except FileProblem as error:
        raise damaged(error, path, advice) from None
    if not isinstance(data, kind):
        raise DamagedFileError(f"{path} is damaged: a JSON {'object' if kind is dict else 'array'} was expected, "
                               f"got {type(data).__name__}; {advice}")
    return data


# ------------------------------------------------------------------------------------- YAML
_FLOAT = re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                    |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                    |[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+\.[0-9_]*
                    |[-+]?\.(?:inf|Inf|INF)
                    |\.(?:nan|NaN|NAN))$""", re.X)
"""YAML 1.1's float pattern (PyYAML's resolver) with the exponent's sign optional and the decimal point
not required, so that ``1e-3``, ``1E3`` and ``3e+4`` are floats, as in YAML 1.2 and JSON."""


class _Refused(Exception):
    """A document beyond the limits (raised inside the loader, reported by :func:`load_yaml`)."""


class _BoundedLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that stops composing at :data:`MAX_NESTING` levels, refuses a key given twice
    in one mapping and reads ``1e-3`` as a float."""

    depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self.depth += 1
        try:
            if self.depth > MAX_NESTING:
                raise _Refused(f"nests deeper than {MAX_NESTING} levels (agents/limits.py)")
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1

    def construct_mapping(self, node: Any, deep: bool = False) -> dict[Any, Any]:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if isinstance(key_node, yaml.ScalarNode) and key_node.tag != "tag:yaml.org,2002:merge":
                    key = self.construct_object(key_node)
                    if key in seen:
                        raise _Refused(f"holds the key {key!r} twice in one mapping (line {key_node.start_mark.line + 1})")
                    seen.add(key)
        return super().construct_mapping(node, deep=deep)


_BoundedLoader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag != "tag:yaml.org,2002:float"]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_BoundedLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))


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


def load_yaml(text: str, where: str, kind: type | tuple[type, ...] | None = None) -> Any:
    """The value of the YAML ``text`` (as ``yaml.safe_load``, numbers as in module docstring), within the limits.

    Parameters
    ----------
    text : str
        The document.
    where : str
        What it is, for the message (a path, ``override 'x=...'``).
    kind : type, optional
        The type the value must have.

    Raises
    ------
    FileProblem
        ``"<where> is not valid YAML: ..."`` (on one line, a control character among the causes),
        ``"<where> nests deeper than 32 levels ..."`` / ``"<where> holds more than 100000 values ..."``
        for a document beyond the limits (the value itself is never printed), ``"<where> holds the key
        'k' twice ..."``, or ``"<where> must hold ..."`` (``kind``).
    """
    loader = None
    try:
        loader = _BoundedLoader(text)  # the reader checks the characters here: a control character is refused
        node = loader.get_single_node()
        if node is None:
            return _require_kind(None, kind, where)
        size = _expanded_size(node, {})
        if size > MAX_YAML_NODES:
            raise _Refused(f"holds more than {MAX_YAML_NODES} values with its aliases expanded (agents/limits.py; "
                           "an alias repeated inside aliases multiplies them)")
        value = loader.construct_document(node)
    except _Refused as error:
        raise FileProblem(f"{where} {error}") from None
    except (yaml.YAMLError, ValueError, RecursionError) as error:  # ValueError: e.g. an integer of 5000 digits
        raise FileProblem(f"{where} is not valid YAML: {_one_line(error)}") from None
    finally:
        if loader is not None:
            loader.dispose()
    return _require_kind(value, kind, where)


def load_yaml_file(path: str | Path, kind: type | tuple[type, ...] | None = None) -> Any:
    """:func:`load_yaml` of the file ``path``, named in every message."""
    return load_yaml(read_text(path), str(path), kind)


# -------------------------------------------------------------------------------------- CSV
def read_csv(path: str | Path, columns: tuple[str, ...] | list[str]) -> list[dict[str, str]]:
    """The rows of a CSV table with a header that holds ``columns`` (others may follow), as mappings.

    Raises
    ------
    FileProblem
        If the file is empty, holds a header only, lacks a column, has a row cut short or of another
        length than the header (the message gives its line), or a field longer than
        :data:`agents.limits.MAX_CSV_FIELD` characters.
    """
    path = stored_path(path)
    text = read_text(path)
    if not text.strip():
        raise FileProblem(f"{path} is empty")
    if not text.endswith("\n"):
        raise FileProblem(f"{path} ends inside a row (its last line has no line end: cut while being written?)")
    previous = csv.field_size_limit(MAX_CSV_FIELD)
    try:
        rows = list(csv.reader(io.StringIO(text, newline=""), strict=True))
    except csv.Error as error:
        raise FileProblem(f"{path} is not a valid table ({_one_line(error)}; fields are at most {MAX_CSV_FIELD} "
                          "characters, agents/limits.py)") from None
    finally:
        csv.field_size_limit(previous)
    header, body = rows[0], rows[1:]
    missing = [name for name in columns if name not in header]
    if missing:
        raise FileProblem(f"{path} lacks the column(s) {', '.join(missing)} (its header: {','.join(header)[:200]})")
    if len(set(header)) != len(header):
        raise FileProblem(f"{path} names a column twice in its header")
    if not body:
        raise FileProblem(f"{path} holds a header and no rows")
    for line, row in enumerate(body, start=2):
        if len(row) != len(header):
            raise FileProblem(f"{path}, line {line}: {len(row)} fields, the header has {len(header)}")
    return [dict(zip(header, row)) for row in body]
