"""``deadtime reproduce``: registry, human and JSON output, figures, and the error for a bad name."""

import json

import pytest

from agents.cli import main
from baselines.reproduction.reproduce import REPRODUCTIONS, reproduce, run_reproductions


def test_unknown_name_lists_the_valid_ones():
    with pytest.raises(ValueError, match="valid names: all, gorez-klan-models"):
        run_reproductions("nope")


def test_cli_reports_a_bad_name_in_one_line(capsys):
    assert main(["reproduce", "nope"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "mu-robustness" in err


def test_json_is_one_object_per_reproduction(capsys, tmp_path):
    assert run_reproductions("gorez-klan-models", as_json=True, figures=tmp_path) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 1
    data = json.loads(lines[0])
    assert set(data) == {"name", "rows", "notes"} and data["name"] == "gorez-klan-models"
    assert set(data["rows"][0]) == {"case", "quantity", "paper", "computed"}
    assert (tmp_path / "gorez-klan-models.png").exists()


def test_human_output_has_deviation_and_rounding_columns(capsys, tmp_path):
    run_reproductions("mu-robustness", figures=tmp_path)
    out = capsys.readouterr().out
    assert "rel. dev." in out and "rounding" in out and "notes:" in out
    assert "mu = 1.3" in out


def test_every_reproduction_has_rows_and_notes():
    for name in ("gorez-klan-models", "mu-robustness", "ingimundarson-fig6"):
        r = reproduce(name)
        assert r.name == name and r.rows and r.notes


@pytest.mark.slow
def test_all_as_json_lines(capsys, tmp_path):
    assert main(["reproduce", "all", "--json", "--figures", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [json.loads(line)["name"] for line in lines] == list(REPRODUCTIONS)
    assert {p.name for p in tmp_path.iterdir()} == {
        "gorez-klan-models.png", "ingimundarson-fig6.png", "ingimundarson-fig7.png", "ingimundarson-fig13.png"
    }
