"""A damaged ``run.json`` of a training run is named before a resume starts (no torch run, no file written).

``run.json`` is rewritten when a session ends; read only then, a damaged one failed the resume after
its training, with a bare JSON error.  The run directories here are made by hand: a resolved config
and the damaged record.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from agents.cli import main
from agents.training.config import load_config

ROOT = Path(__file__).resolve().parents[4]

DAMAGES = {
    "truncated": ('{"algorithm": "SAC", "status": "interr', "is damaged: not valid JSON ("),
    "binary": ("\x00\x01garbage", "is damaged: not valid JSON ("),
    "not-an-object": ("[1, 2]", "is damaged: a JSON object was expected, got list"),
}


def _snapshot(directory: Path) -> dict[str, bytes]:
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


@pytest.mark.parametrize(("text", "message"), DAMAGES.values(), ids=DAMAGES.keys())
def test_a_damaged_run_json_is_named_before_the_resume_starts(tmp_path: Path, capsys, text: str, message: str) -> None:
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    config = load_config(ROOT / "configs" / "sac.yaml", env_id="DeadTime/PID-v0")
    (run_dir / "config.yaml").write_text(yaml.safe_dump(config.to_dict(), sort_keys=False))
    (run_dir / "run.json").write_text(text)
    before = _snapshot(run_dir)
    assert main(["train", "--out", str(run_dir), "--resume"]) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1, captured.err
    assert captured.err.startswith(f"deadtime train: error: {run_dir / 'run.json'} {message}"), captured.err
    assert captured.err.rstrip().endswith("restore it, or move it away to start its record afresh")
    assert _snapshot(run_dir) == before
