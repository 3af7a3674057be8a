"""Each line of ``cache.jsonl`` (agents.evaluation.cache) is used only if its checksum matches and its
result is well formed; any other line is recomputed and said once, naming the file."""

from __future__ import annotations

import json
import math

import pytest

from agents.cli import main
from agents.evaluation.cache import Cache, line_digest
from agents.evaluation.result import PolicyResult

GOOD = PolicyResult(2.063, True, False, 1.0, {"type": "pi"}, 0.5)


def _line(key: str, policy: str, result: dict, digest: str | None) -> str:
    entry = {"key": key, "policy": policy, "result": result}
    return json.dumps({**entry, **({} if digest is None else {"sha256": digest})}) + "\n"


def _signed(result: dict) -> str:
    return _line("k", "p", result, line_digest("k", "p", result))


EDITS = {
    "cost-edited": _line("k", "p", {**GOOD.to_dict(), "cost": 0.001}, line_digest("k", "p", GOOD.to_dict())),
    "cost-nan": _line("k", "p", {**GOOD.to_dict(), "cost": math.nan}, line_digest("k", "p", GOOD.to_dict())),
    "cost-text-resigned": _signed({**GOOD.to_dict(), "cost": "abc"}),
    "cost-nan-resigned": _signed({**GOOD.to_dict(), "cost": math.nan}),
    "unknown-field-resigned": _signed({**GOOD.to_dict(), "extra": 1}),
    "no-checksum": _line("k", "p", GOOD.to_dict(), None),
    "not-an-object": _line("k", "p", [], line_digest("k", "p", [])),
}


@pytest.mark.parametrize("line", EDITS.values(), ids=EDITS.keys())
def test_an_untrusted_line_is_recomputed_and_said_once(tmp_path, line):
    path = tmp_path / "cache.jsonl"
    path.write_text(line)
    cache = Cache(path)
    assert cache.get("k", "p") is None
    assert cache.note() == (f"{path}: dropped 1 line(s) that failed the integrity check (checksum missing or wrong, "
                            "or malformed); their results were computed again")
    cache.put("k", "p", GOOD)
    again = Cache(path)
    assert again.get("k", "p") == GOOD
    assert again.note() is None  # superseded by the recomputed line: not said again


def test_an_untrusted_line_never_asked_for_is_not_reported(tmp_path):
    path = tmp_path / "cache.jsonl"
    path.write_text(_line("old-key", "p", GOOD.to_dict(), None))  # e.g. a line of an older cache version
    cache = Cache(path)
    assert cache.get("k", "p") is None
    assert cache.note() is None


def test_a_line_cut_short_is_cut_off_by_the_next_append(tmp_path):
    path = tmp_path / "cache.jsonl"
    path.write_text(_signed(GOOD.to_dict()) + '{"key": "a", "policy": "p", "result": {"cost": 1.0, "feas')
    cache = Cache(path)
    assert cache.entries == {("k", "p"): GOOD}
    cache.put("b", "p", GOOD)
    assert Cache(path).entries == {("k", "p"): GOOD, ("b", "p"): GOOD}
    assert Cache(path).note() is None
    assert path.read_text().count("\n") == 2


def test_garbage_lines_are_counted(tmp_path):
    path = tmp_path / "cache.jsonl"
    path.write_text("not json\n" + _signed(GOOD.to_dict()) + '{"key": 1, "policy": "p"}\n')
    cache = Cache(path)
    assert cache.get("k", "p") == GOOD
    assert cache.note().startswith(f"{path}: dropped 2 line(s)")


def test_evaluate_recomputes_an_edited_cost_and_says_so(capsys, tmp_path):
    """A cost edited in the file (to 0.001) is not used: the plant is scored again and the line said."""
    argv = ["evaluate", "--env", "DeadTime/FPPI-v0", "--n", "1", "--seed", "3", "--policies", "ppi-kappa1,oracle",
            "--no-benchmark", "--no-plots", "--json", "--out", str(tmp_path)]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    path = tmp_path / "cache.jsonl"
    lines = path.read_text().splitlines()
    edited = [json.loads(line) for line in lines]
    edited[0]["result"]["cost"] = 0.001
    path.write_text("".join(json.dumps(entry) + "\n" for entry in edited))
    assert main(argv) == 0
    captured = capsys.readouterr()
    second = json.loads(captured.out)
    first.pop("wall_time_s"), second.pop("wall_time_s")
    assert second == first
    notes = [line for line in captured.err.splitlines() if "cache.jsonl" in line]
    assert notes == [f"deadtime evaluate: {path}: dropped 1 line(s) that failed the integrity check (checksum missing or "
                     "wrong, or malformed); their results were computed again"]
