"""``deadtime study headroom``: its cache never gives another protocol's costs, and a refused run writes nothing."""

from __future__ import annotations

import io
import json
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from tiny_protocol import write_tiny_protocol

from agents.cli import main
from agents.studies import headroom as study


def _protocol(tmp_path: Path, entropy: int) -> Path:
    """The tiny protocol (tests/tiny_protocol.py) of validation stream ``entropy``."""
    return write_tiny_protocol(tmp_path, entropy=entropy, file_name=f"p{entropy}")


@pytest.fixture
def plant_costs(monkeypatch):
    """Costs that depend on the plant only (the study's episodes are checked in test_headroom.py)."""
    def fake(env, plant, seed, replicates, weights, design="base", **_):
        rng = np.random.default_rng(abs(hash(json.dumps(plant.to_dict(), sort_keys=True))) % 2**32)
        return rng.uniform(1.0, 2.0, (len(study.GRID), len(study.GRID), replicates, len(weights)))
    monkeypatch.setattr(study, "plant_costs", fake)


def test_a_second_protocol_with_other_streams_gets_its_own_costs(tmp_path, plant_costs):
    """Two protocols of one structure and noise level but other streams: each its own costs, on one ``--out``."""
    first, second = _protocol(tmp_path, 11), _protocol(tmp_path, 13)
    out = tmp_path / "out"
    table_first = study.headroom(first, 3, 2, out)
    table_second = study.headroom(second, 3, 2, out)
    assert table_second != table_first
    assert table_second == study.headroom(second, 3, 2, tmp_path / "fresh")
    assert len(list((out / "work").glob("*.npz"))) == 2
    assert study.headroom(first, 3, 2, out) == table_first  # read back from its own file


def test_a_cache_of_another_key_is_not_read(tmp_path, plant_costs):
    path = _protocol(tmp_path, 11)
    out = tmp_path / "out"
    table = study.headroom(path, 3, 2, out)
    (cache,) = (out / "work").glob("*.npz")
    with np.load(cache) as found:
        key, costs = str(found["key"]), found["costs"]
    np.savez_compressed(cache.with_suffix(".tmp.npz"), costs=costs + 5.0, key=np.array(key.replace('"version": 1', '"version": 0')))
    cache.with_suffix(".tmp.npz").replace(cache)
    assert study.headroom(path, 3, 2, out) == table  # computed again, not read
    cache.write_bytes(b"damaged")
    assert study.headroom(path, 3, 2, out) == table


@pytest.mark.parametrize("options, message", [
    (["--plants", "0"], "--plants must be an integer in [2, 5]"),
    (["--plants", "6"], "--plants must be an integer in [2, 5]"),
    (["--plants", "3", "--replicates", "1"], "--replicates must be an integer in [2, 1000]"),
    (["--plants", "3", "--replicates", str(10**12)], "--replicates must be an integer in [2, 1000]"),
])
def test_a_refused_run_writes_nothing(tmp_path, options, message):
    """Sizes out of range are refused in one line before ``--out`` is created."""
    path = _protocol(tmp_path, 11)
    out = tmp_path / "out"
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        status = main(["study", "headroom", "--protocol", str(path), *options, "--out", str(out)])
    assert status == 2 and message in err.getvalue() and len(err.getvalue().strip().splitlines()) == 1
    assert not out.exists()


def test_headroom_has_no_default_out_inside_the_repository(tmp_path):
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err), pytest.raises(SystemExit) as exit_:
        main(["study", "headroom", "--protocol", str(_protocol(tmp_path, 11)), "--plants", "0"])
    assert exit_.value.code == 2 and "--out" in err.getvalue()
    with pytest.raises(ValueError, match="--out is required"):
        study.headroom(_protocol(tmp_path, 11), 3, 2, None)
