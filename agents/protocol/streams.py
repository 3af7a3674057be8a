"""The protocol's plant streams and the registry of test seeds.

A stream of plants of a family is ``numpy.random.SeedSequence(entropy, spawn_key=(family index,))``
fed to :func:`envs.systems.families.sample_plant`, one plant after another, so that the ``i``-th
plant does not depend on the stream's length.  A non-empty spawn key makes a stream that no integer
training seed reproduces (the learners' training plants come from ``default_rng(seed)``), and an
entropy other than :data:`envs.systems.plant_sets.PLANT_SET_ENTROPY` one that differs from the
validation and test sets every study before the protocol used.

The registry (``configs/protocols/test_seeds.json``) lists each test entropy with the protocol that
consumes it (path and sha256).  A run evaluates its test stream only when the protocol's entropy is
registered with the protocol's own sha256: a protocol changed after its registration, or another
protocol on the same entropy, is refused in one line (a changed protocol takes a fresh test seed).
An entry with ``superseded_by`` is retired: its protocol was replaced before any evaluation, and its
entropy is never evaluated.  Every field is checked where the registry is read (``entropy`` an integer,
``protocol`` a string, ``sha256`` and ``superseded_by`` 64 hexadecimal digits); a registration holds a
lock beside the file while it reads, adds and writes it (atomically), so that two registrations at
once both keep their entries.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.reader import read_json

__all__ = ["REGISTRY", "TestSeedRefused", "check_test_seed", "plant_stream", "read_registry", "register_test_seed"]

REGISTRY = Path("configs/protocols/test_seeds.json")
"""The registry of test entropies, relative to the repository's root (the directory commands run in)."""


class TestSeedRefused(ValueError):
    """A test stream that this protocol may not evaluate (its entropy is not registered to it)."""

    __test__ = False  # not a pytest class


def plant_stream(family: str, entropy: int, n: int) -> list[Any]:
    """The first ``n`` plants of the stream of ``family`` with ``entropy`` (module docstring)."""
    from envs.systems.families import FAMILIES, sample_plant
    from envs.systems.plant_sets import PLANT_SET_ENTROPY

    if family not in FAMILIES:
        raise ValueError(f"unknown plant family {family!r}; valid families: {', '.join(FAMILIES)}")
    if entropy == PLANT_SET_ENTROPY:
        raise ValueError(f"entropy {entropy} is that of the fixed validation and test sets of every earlier study; "
                         "a protocol's streams need their own")
    rng = np.random.default_rng(np.random.SeedSequence(entropy, spawn_key=(FAMILIES.index(family),)))
    return [sample_plant(family, rng) for _ in range(int(n))]


_SHA256 = re.compile(r"[0-9a-f]{64}")
_FIELDS = {"entropy", "protocol", "sha256", "superseded_by"}


def _entry(entry: Any, where: str) -> dict[str, Any]:
    """``entry`` if its fields are of their types (module docstring), else one line naming the field."""
    if not isinstance(entry, dict) or not {"entropy", "protocol", "sha256"} <= entry.keys():
        raise ValueError(f"{where} must be an object with entropy, protocol and sha256")
    unknown = sorted(set(entry) - _FIELDS)
    if unknown:
        raise ValueError(f"{where} has the unknown field {unknown[0]!r} (fields: {', '.join(sorted(_FIELDS))})")
    entropy = entry["entropy"]
    if isinstance(entropy, bool) or not isinstance(entropy, int) or entropy < 0:
        raise ValueError(f"{where}.entropy must be an integer >= 0, got {entropy!r}")
    if not isinstance(entry["protocol"], str) or not entry["protocol"]:
        raise ValueError(f"{where}.protocol must be the protocol's path, got {entry['protocol']!r}")
    for field in ("sha256", "superseded_by"):
        if field in entry and not (isinstance(entry[field], str) and _SHA256.fullmatch(entry[field])):
            raise ValueError(f"{where}.{field} must be a sha256 (64 hexadecimal digits), got {entry[field]!r}")
    return entry


def read_registry(path: Path = REGISTRY) -> list[dict[str, Any]]:
    """The registry's entries, ``{"entropy", "protocol", "sha256"}`` each (an absent file: none).

    Raises
    ------
    ValueError
        One line naming the file and the entry's field that is missing or of the wrong type.
    """
    if not path.exists():
        return []
    entries = read_json(path)
    if not isinstance(entries, list):
        raise ValueError(f"{path}: must be a JSON list of {{entropy, protocol, sha256}}")
    return [_entry(entry, f"{path}: entry {i}") for i, entry in enumerate(entries)]


def check_test_seed(entropy: int, sha256: str, path: Path = REGISTRY) -> dict[str, Any]:
    """The registry entry of ``entropy`` if it is registered to the protocol of ``sha256``.

    Raises
    ------
    TestSeedRefused
        One line: the entropy is not registered, or registered to another protocol's sha256.
    """
    for entry in read_registry(path):
        if entry["entropy"] == entropy:
            if entry["sha256"] != sha256:
                raise TestSeedRefused(
                    f"test seed {entropy} was registered to {entry['protocol']} with sha256 {entry['sha256'][:12]}, "
                    f"this protocol's is {sha256[:12]}: a changed protocol takes a fresh test seed")
            if entry.get("superseded_by"):
                raise TestSeedRefused(f"test seed {entropy} was retired (its protocol was superseded by sha256 "
                                      f"{entry['superseded_by'][:12]} before any evaluation): it is never evaluated")
            return entry
    raise TestSeedRefused(f"test seed {entropy} is not registered in {path}: register it "
                          "(deadtime protocol register) in a commit before any result of the protocol")


def register_test_seed(entropy: int, protocol: str, sha256: str, path: Path = REGISTRY) -> dict[str, Any]:
    """Add ``entropy`` to the registry for the protocol of ``sha256``; refused if any protocol has it
    (the same protocol again: the entry as it is).  The file is read, extended and written (atomically)
    under :func:`agents.files.lock.file_lock`: registrations at once keep every entry."""
    from agents.files.lock import file_lock
    from agents.files.writer import write_text

    if not path.parent.is_dir():
        raise ValueError(f"{path}: no such folder {path.parent}")
    with file_lock(path):
        entries = read_registry(path)
        for entry in entries:
            if entry["entropy"] == entropy:
                if entry["sha256"] == sha256:
                    return entry
                raise TestSeedRefused(f"test seed {entropy} is already registered to {entry['protocol']} "
                                      f"(sha256 {entry['sha256'][:12]}): choose a fresh one")
        entry = {"entropy": entropy, "protocol": protocol, "sha256": sha256}
        write_text(path, json.dumps([*entries, entry], indent=2) + "\n")
    return entry
