"""Checkpoints of ``deadtime train``: what one holds, how it is written, verified and restored.

A checkpoint of ``N`` steps is, in ``<run>/checkpoints``:

* ``model_N.zip``: the stable-baselines3 model (network and optimizer states, ``num_timesteps``,
  ``_n_updates``, ``_episode_num``, ``_last_obs``, ``_last_episode_starts``, ``_last_original_obs``,
  ``ep_info_buffer``, the schedules and ``_current_progress_remaining``);
* ``replay_buffer_N.pkl`` (off-policy algorithms) and ``vecnormalize_N.pkl`` (if used), and the
  observation statistics again as data, ``normalization_N.json``, for playing the checkpoint's model
  (:mod:`agents.training.normalization`);
* ``state_N.pkl``: what stable-baselines3 does not save: the random states of Python's ``random``,
  numpy's global generator and torch (CPU), the generator of the model's action space (the warm-up
  actions), every training environment whole (pickled inside its :class:`SnapshotWrapper`: its
  ``np_random``, the episode in progress and the ``Monitor``'s counters), the running returns of
  ``VecNormalize`` (which its own pickle leaves out) and the action noise;
* ``checkpoint_N.json``, the manifest, written last: the files with their sizes and SHA-256, the
  validation history and the checkpoint schedule.  ``latest.json`` is a copy of the newest manifest.

A checkpoint is taken at the start of a rollout, after the previous rollout was trained on.  Restored
in that order (model, replay buffer, environments, then the random states last, since building the
networks draws from torch's generator), it continues exactly as the uninterrupted run did.

:func:`find_checkpoint` returns the newest checkpoint whose manifest and files are intact (sizes and
checksums as recorded), with one line naming the damaged file if it had to fall back on an older one.
The last two checkpoints are kept.
"""

from __future__ import annotations

import copy
import json
import pickle
import random
import re
import zipfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np

from agents.files.reader import DamagedFileError, FileProblem, damaged, read_json
from agents.files.writer import atomic_write, file_digest, write_json

__all__ = [
    "CHECKPOINT_INDEX",
    "Checkpoint",
    "DamagedFileError",
    "SnapshotWrapper",
    "capture_state",
    "find_checkpoint",
    "load_file",
    "read_manifest",
    "restore_state",
    "save_checkpoint",
]

CHECKPOINT_INDEX = "latest.json"
ROLES = ("model", "replay_buffer", "vecnormalize", "normalization", "state")
KEEP = 2
_SUFFIXES = {"model": "zip", "normalization": "json"}
_MANIFEST = re.compile(r"checkpoint_(\d+)\.json")
_STEPS = re.compile(r"(model|replay_buffer|vecnormalize|normalization|state|checkpoint)_(\d+)\.(zip|pkl|json)")
# What a damaged or foreign file raises when loaded (pickle, zip, torch, numpy, SB3's own checks).
LOAD_ERRORS = (pickle.UnpicklingError, EOFError, zipfile.BadZipFile, ValueError, KeyError, OSError,
               AttributeError, TypeError, RuntimeError, IndexError, ImportError)


# ----------------------------------------------------------------------------------- environments
class SnapshotWrapper(gymnasium.Wrapper):
    """The outermost wrapper of a training environment: saves and restores everything inside it.

    Called through ``VecEnv.env_method``, so it works alike in ``DummyVecEnv`` and ``SubprocVecEnv``.
    """

    def checkpoint_snapshot(self) -> bytes:
        """The wrapped environment pickled whole (random generator and episode in progress)."""
        return pickle.dumps(self.env)

    def checkpoint_restore(self, snapshot: bytes) -> None:
        """Replace the wrapped environment by a snapshot of :meth:`checkpoint_snapshot`."""
        self.env = pickle.loads(snapshot)  # noqa: S301  (our own checkpoint, verified by checksum)


def _check_modules(snapshot: bytes) -> None:
    """Refuse, in one line, an environment snapshot that names modules this code no longer has.

    A pickle names its classes by module path: a checkpoint whose environments name a module that
    is now elsewhere (e.g. ``envs.scoring``, now ``envs.analysis.scoring``) cannot be resumed.
    """
    try:
        pickle.loads(snapshot)  # noqa: S301  (our own checkpoint, verified by checksum)
    except ModuleNotFoundError as error:
        raise ValueError(f"the checkpoint's environments name the module {error.name!r}, which this version does not "
                         "have (its modules were moved since): resume it with the commit in the run's config.yaml, or "
                         "start a new run") from None


# ----------------------------------------------------------------------------------- state
def capture_state(model: Any, vecnormalize: Any = None) -> dict[str, Any]:
    """What a model zip, replay buffer and ``VecNormalize`` pickle leave out (see the module docstring)."""
    import torch

    return {
        "python_random": random.getstate(),
        "numpy_random": np.random.get_state(),  # noqa: NPY002  (SB3's buffers draw from it)
        "torch_random": torch.get_rng_state(),
        "action_space_random": model.action_space.np_random.bit_generator.state,
        "environments": model.get_env().env_method("checkpoint_snapshot"),
        "vecnormalize_returns": None if vecnormalize is None else vecnormalize.returns.copy(),
        "action_noise": copy.deepcopy(model.action_noise),
    }


def restore_state(state: Mapping[str, Any], model: Any, vecnormalize: Any = None) -> None:
    """Put a :func:`capture_state` back, random states last (the action noise: :func:`restore_action_noise`)."""
    import torch

    venv = model.get_env()
    for index, snapshot in enumerate(state["environments"]):
        _check_modules(snapshot)
        venv.env_method("checkpoint_restore", snapshot, indices=[index])
    base = venv.unwrapped
    base._seeds = [None] * base.num_envs  # loading reseeded them for a reset that never comes  # noqa: SLF001
    if vecnormalize is not None:
        vecnormalize.returns = state["vecnormalize_returns"].copy()
    model.action_space.np_random.bit_generator.state = state["action_space_random"]
    random.setstate(state["python_random"])
    np.random.set_state(state["numpy_random"])  # noqa: NPY002
    torch.set_rng_state(state["torch_random"])


def restore_action_noise(state: Mapping[str, Any], model: Any) -> None:
    """The action noise as saved; call after ``learn`` has set up (it resets the noise)."""
    model.action_noise = copy.deepcopy(state["action_noise"])


# ----------------------------------------------------------------------------------- writing
def save_checkpoint(
    directory: Path,
    model: Any,
    vecnormalize: Any,
    evaluations: Sequence[Mapping[str, Any]],
    periodic: int,
) -> Path:
    """Write the checkpoint of ``model.num_timesteps`` steps; return its manifest.

    ``periodic`` is the step of the last periodic checkpoint (the schedule continues from it on resume).
    """
    steps = model.num_timesteps
    writers: dict[str, Callable[[Any], None]] = {"model": model.save}
    if getattr(model, "replay_buffer", None) is not None:
        writers["replay_buffer"] = model.save_replay_buffer
    if vecnormalize is not None:
        from agents.training.normalization import statistics_record

        writers["vecnormalize"] = lambda handle: pickle.dump(vecnormalize, handle)
        record = (json.dumps(statistics_record(vecnormalize), indent=2) + "\n").encode()
        writers["normalization"] = lambda handle: handle.write(record)
    state = capture_state(model, vecnormalize)
    writers["state"] = lambda handle: pickle.dump(state, handle)
    manifest: dict[str, Any] = {"format": 2, "num_timesteps": steps, "periodic_checkpoint": periodic,
                                "files": {}, "evaluations": list(evaluations)}
    for role, write in writers.items():
        name = f"{role}_{steps}.{_SUFFIXES.get(role, 'pkl')}"
        path = atomic_write(directory / name, write)
        manifest[role] = name
        manifest["files"][name] = {"bytes": path.stat().st_size, "sha256": file_digest(path)}
    path = write_json(directory / f"checkpoint_{steps}.json", manifest)
    write_json(directory / CHECKPOINT_INDEX, manifest)
    _prune(directory)
    return path


def _prune(directory: Path) -> None:
    """Keep the files of the newest :data:`KEEP` manifests."""
    steps = sorted(int(m.group(1)) for p in directory.iterdir() if (m := _MANIFEST.fullmatch(p.name)))
    keep = set(steps[-KEEP:])
    for path in directory.iterdir():
        match = _STEPS.fullmatch(path.name)
        if match and int(match.group(2)) not in keep:
            path.unlink(missing_ok=True)


# ----------------------------------------------------------------------------------- reading
@dataclass(frozen=True)
class Checkpoint:
    """A checkpoint read from its manifest."""

    manifest: Path
    num_timesteps: int
    files: Mapping[str, str | None]
    evaluations: tuple[Mapping[str, Any], ...] = ()
    periodic_checkpoint: int = 0
    checksums: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def path(self, role: str) -> Path | None:
        """The file of ``role`` (``model``, ``replay_buffer``, ``vecnormalize``, ``state``), or None."""
        name = self.files.get(role)
        return None if not name else self.manifest.parent / name

    def verify(self) -> None:
        """Check that every file exists and has the recorded size and checksum.

        Raises
        ------
        DamagedFileError
            Naming the first missing or damaged file.
        """
        for role in ROLES:
            path = self.path(role)
            if path is None:
                continue
            if not path.is_file():
                raise DamagedFileError(f"{path} is missing (named by {self.manifest.name})")
            expected = self.checksums.get(path.name)
            if expected is None:
                continue  # a checkpoint of an older format: checked when loaded
            size = path.stat().st_size
            if size != expected["bytes"]:
                raise DamagedFileError(f"{path} is damaged: {size} bytes, {expected['bytes']} when saved (truncated?)")
            if file_digest(path) != expected["sha256"]:
                raise DamagedFileError(f"{path} is damaged: its SHA-256 differs from the one recorded when it was saved")


def read_manifest(path: Path) -> Checkpoint:
    """Read a checkpoint manifest (``checkpoint_N.json`` or ``latest.json``).

    Raises
    ------
    DamagedFileError
        If it cannot be read or is not a manifest (the message names the file and what is wrong).
    """
    try:
        data = read_json(path)
    except FileProblem as error:
        raise damaged(error, path) from None
    if not isinstance(data, dict) or not isinstance(data.get("num_timesteps"), int) or not isinstance(data.get("model"), str):
        raise DamagedFileError(f"{path} is damaged: not a checkpoint manifest (num_timesteps and model are required)")
    files = {role: data.get(role) for role in ROLES}
    if any(name is not None and (not isinstance(name, str) or "/" in name or "\\" in name) for name in files.values()):
        raise DamagedFileError(f"{path} is damaged: a file name is not a plain name in its directory")
    evaluations = data.get("evaluations", [])
    if not isinstance(evaluations, list) or not all(isinstance(e, dict) and "mean_cost" in e for e in evaluations):
        raise DamagedFileError(f"{path} is damaged: evaluations must be a list of validation results")
    return Checkpoint(manifest=path, num_timesteps=data["num_timesteps"], files=files, evaluations=tuple(evaluations),
                      periodic_checkpoint=int(data.get("periodic_checkpoint", data["num_timesteps"])),
                      checksums=data.get("files") or {})


def _manifests(directory: Path) -> list[Path]:
    """``latest.json``, then the ``checkpoint_N.json`` newest first (a kill can fall between the two writes)."""
    numbered = sorted((int(m.group(1)), p) for p in directory.glob("checkpoint_*.json") if (m := _MANIFEST.fullmatch(p.name)))
    index = directory / CHECKPOINT_INDEX
    return ([index] if index.exists() else []) + [p for _, p in reversed(numbered)]


def find_checkpoint(run_dir: str | Path) -> tuple[Checkpoint | None, str | None]:
    """The newest intact checkpoint of a run, and a line naming what was skipped to reach it.

    Returns
    -------
    checkpoint : Checkpoint or None
        None if the run has no checkpoint yet.
    note : str or None
        Set when the newest checkpoint was damaged and an older one is returned.

    Raises
    ------
    DamagedFileError
        If there are checkpoints but none is intact (naming the newest one's damaged file).
    """
    directory = Path(run_dir) / "checkpoints"
    if not directory.is_dir():
        return None, None
    problems: list[str] = []
    readable = []
    for manifest in _manifests(directory):
        try:
            readable.append(read_manifest(manifest))
        except DamagedFileError as error:
            problems.append(str(error))
    failed: set[int] = set()
    for checkpoint in sorted(readable, key=lambda c: -c.num_timesteps):  # newest first, whichever manifest names it
        if checkpoint.num_timesteps in failed:
            continue
        try:
            checkpoint.verify()
        except DamagedFileError as error:
            problems.append(str(error))
            failed.add(checkpoint.num_timesteps)
            continue
        if not problems:
            return checkpoint, None
        return checkpoint, (f"{problems[0]}; resuming from {checkpoint.manifest.name} "
                            f"({checkpoint.num_timesteps} steps) instead")
    if problems:
        raise DamagedFileError(f"{problems[0]}; no intact checkpoint to resume from (start a new run in another --out)")
    return None, None


def load_file(path: Path, load: Callable[[Path], Any]) -> Any:
    """``load(path)``, with any error of a damaged file turned into a :class:`DamagedFileError` naming it."""
    try:
        return load(path)
    except LOAD_ERRORS as error:
        raise DamagedFileError(f"{path} could not be loaded ({error.__class__.__name__}: {error})") from None


def read_pickle(path: Path) -> Any:
    """Unpickle a file of a run."""
    with path.open("rb") as handle:
        return pickle.load(handle)  # noqa: S301  (the run's own file)
