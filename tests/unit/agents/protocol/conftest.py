"""A tiny protocol for the tests of its run: two regimes, two seeds, a few plants, 20 training plants per fit."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from tiny_protocol import write_tiny_protocol

from agents.protocol.config import load_protocol


def write_two_regimes(folder: Path) -> Path:
    """The tiny protocol (tests/tiny_protocol.py) of two regimes, 20 training plants per fit, 4 validation and
    5 test plants, written into ``folder`` and registered.  Its path."""
    return write_tiny_protocol(folder, regimes={"pid-quiet": 0.01, "pid-noisy": 0.05}, plants=(20, 4, 5),
                               comparisons="[[fixed, best-rule], [plan, best-rule], [plan, fixed-procedure]]", register=True)


@pytest.fixture(autouse=True, scope="session")
def _uncommitted_code_allowed() -> Iterator[None]:
    """The protocol runs of these tests run from the tree under test, committed or not (their protocol.json
    marked so where it is not); tests/unit/agents/protocol/test_code.py checks the refusal itself."""
    import os

    before = os.environ.get("DEADTIME_UNCOMMITTED_CODE")
    os.environ["DEADTIME_UNCOMMITTED_CODE"] = "1"
    yield
    if before is None:
        os.environ.pop("DEADTIME_UNCOMMITTED_CODE")
    else:
        os.environ["DEADTIME_UNCOMMITTED_CODE"] = before


@pytest.fixture
def tiny_protocol() -> Callable[[Path], Path]:
    """:func:`write_two_regimes`."""
    return write_two_regimes


@pytest.fixture(scope="module")
def tiny_serial_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The tiny protocol run in this process, one task after another: its path and its run folder."""
    from agents.protocol.run import run_protocol

    folder = tmp_path_factory.mktemp("serial")
    path = write_two_regimes(folder)
    assert run_protocol(load_protocol(path), folder / "out") == ["pid-quiet", "pid-noisy"]
    return path, folder / "out"
