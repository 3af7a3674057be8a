"""Each number of README.md and docs/ that a fast command or a committed summary produces, compared
with that command's output or that summary.

The demo's numbers need a training run and are not checked here (docs/training_and_evaluation.md
marks the agent's row as varying across machines).  The ``tune`` rows are deterministic closed forms
to the printed digits (SIMC on ``2.5 e^{-4s}/(12 s + 1)``: ``K_c = 0.6``, ``T_i = 12``; ZN's step PI
has ``Ms = 2.566``); the ``T_r`` floors are measured by ``test_tr_floors_are_the_exact_model_delay_margin``.
The README's protocol tables are held to the committed reports by ``tests/unit/test_results.py``; the
selector's choices per band of docs/selector.md are ``deadtime study selector-choices``'s committed output.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from in_process import run_deadtime as run

REPO = Path(__file__).resolve().parents[2]
README = (REPO / "README.md").read_text()
DOCS = REPO / "docs"
COMMAND_LINE = (DOCS / "command_line.md").read_text()
MODEL = '{"type": "fopdt", "gain": 2.5, "time_constant": 12, "dead_time": 4}'


def test_the_exit_3_line_is_what_tune_prints():
    line = re.search(r"`(deadtime tune: zn-step-pi gives [^`]*)`", COMMAND_LINE.replace("\n", " ")).group(1)
    assert run("tune", "--rule", "zn-step-pi", "--model", MODEL)[2] == line + "\n"


def test_the_model_only_example_runs_as_written():
    for text in (README, COMMAND_LINE):
        assert f"deadtime tune --rule simc-pi --model '{MODEL}' --json" in text
    status, out, _ = run("tune", "--rule", "simc-pi", "--model", MODEL, "--json")
    controller = json.loads(out)["controller"]
    assert status == 0 and (controller["kp"], controller["ti"]) == (0.6, 12.0)


def test_the_tr_floors_are_those_of_the_code():
    from baselines.rules.tune import TR_FLOORS

    assert f"`{TR_FLOORS['fppi']:g} L_n` (FPPI) or `{TR_FLOORS['msp']:g} L_n` (MSP)" in COMMAND_LINE.replace("\n", " ")


def test_the_tclab_model_is_what_the_procedure_identifies():
    """docs/real_process.md: the identified heater-1 loop (seed 0), as printed."""
    from envs.process.procedure import identify_process
    from envs.process.tclab_process import TCLabProcess

    found = identify_process(TCLabProcess(), seed=0)
    i, relay, point = found.identification, found.relay, found.operating_point
    section = (DOCS / "real_process.md").read_text().replace("\n", " ")
    for printed in ("38.77 degC", f"`K_n = {i.gain:.3f} degC/%`", f"`T_ar = {i.residence_time:.0f} s`",
                    f"`tau = {i.closed_loop.normalized_dead_time:.3f}`", f"`T_n = {i.fopdt.time_constant:.0f} s`",
                    f"`L_n = {i.fopdt.dead_time:.1f} s`", f"`D_2 = {i.sopdt.dead_time:.1f} s`",
                    f"`K_u = {relay.ultimate_gain:.0f} %/degC`", f"`T_u = {relay.ultimate_period:.1f} s`"):
        assert printed in section, printed
    assert f"{point.output:.2f}" == "38.77"


def test_the_selector_choice_tables_are_the_committed_study():
    """docs/selector.md's tables of the selector's choices per dead-time band are rows of
    ``deadtime study selector-choices``'s committed output."""
    page = (DOCS / "selector.md").read_text().splitlines()
    study = set((REPO / "results" / "protocol_v3" / "choices" / "choices.md").read_text().splitlines())
    rows = [line for line in page if re.match(r"\| \d\.\d-\d\.\d \|", line)]
    assert len(rows) >= 5 and [row for row in rows if row not in study] == []
