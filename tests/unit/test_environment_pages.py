"""docs/environments/<name>.md are generated from the environments (:mod:`agents.environment_pages`).

Each committed page is what the generator writes now, from the class docstring and the registered
ids, and the page of the shared sections (``common.md``) what it writes from ``envs.env_cards``; a page edited by hand, or a docstring or registration changed without rerunning the generator,
fails here with the command that regenerates the pages.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.environment_pages import COMMAND, COMMON, PAGES, common_page, environment_names, main, page

NAMES = environment_names()


@pytest.mark.parametrize("name", sorted(NAMES))
def test_the_committed_page_is_the_generated_one(name: str) -> None:
    path = PAGES / f"{name.lower()}.md"
    assert path.is_file(), f"{path} is missing; generate it with: {COMMAND}"
    assert path.read_text() == page(name, NAMES[name]), f"{path} is stale; regenerate it with: {COMMAND}"


def test_the_committed_common_page_is_the_generated_one() -> None:
    path = PAGES / COMMON
    assert path.is_file() and path.read_text() == common_page(NAMES), f"{path} is stale; regenerate it with: {COMMAND}"


def test_a_shared_section_is_written_once_and_a_structure_s_own_on_its_page() -> None:
    """PID's Rewards are the shared text: a link on pid.md, the text on common.md; PI's Version
    History is its own: on pi.md, and common.md's is PID's, FPPI's and MSP's."""
    from envs.env_cards import PI_VERSION_HISTORY, VERSION_HISTORY

    pid, pi, common = page("PID", NAMES["PID"]), page("PI", NAMES["PI"]), common_page(NAMES)
    assert "capped at 20" in common and "capped at 20" not in pid
    assert f"[Rewards]({COMMON}#rewards)" in pid and f"[Version History]({COMMON}#version-history)" in pid
    assert "initial version: the structure `pi`" in pi and "initial version: the structure" not in common
    assert "Of FPPI, MSP, PID." in common and VERSION_HISTORY != PI_VERSION_HISTORY
    assert "| 18 | `design_step` |" in pid and 'family="integrating"' in page("MSP", NAMES["MSP"])


def test_every_registered_environment_has_a_page_and_no_hand_kept_page_is_left() -> None:
    assert {"PID", "FPPI", "MSP"} <= set(NAMES)
    generated = {PAGES / f"{name.lower()}.md" for name in NAMES} | {PAGES / COMMON}
    hand_kept = {path for path in PAGES.glob("*.md") if path.name != "overview.md"} - generated
    assert not hand_kept, f"pages of no registered environment: {sorted(p.name for p in hand_kept)}"


def test_the_check_names_a_stale_page_and_the_command(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    import agents.environment_pages as module

    folder = tmp_path / "docs" / "environments"
    folder.mkdir(parents=True)
    monkeypatch.setattr(module, "PAGES", folder)
    monkeypatch.setattr(module, "pages", lambda: {folder / "pid.md": "# PID\n"})
    (folder / "pid.md").write_text("# PID, edited by hand\n")
    assert main(["--check"]) == 1
    assert f"docs/environments/pid.md is stale; regenerate it with: {COMMAND}" in capsys.readouterr().err
    assert main([]) == 0 and (folder / "pid.md").read_text() == "# PID\n"
    assert main(["--check"]) == 0
