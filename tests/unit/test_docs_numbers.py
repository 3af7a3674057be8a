"""Each number of README.md and docs/ that a fast command or a committed summary produces, compared
with that command's output or that summary.

The demo's numbers need a training run and are not checked here (docs/training_and_evaluation.md
marks the agent's row as varying across machines).  The ``tune`` rows are deterministic closed forms
to the printed digits (SIMC on ``2.5 e^{-4s}/(12 s + 1)``: ``K_c = 0.6``, ``T_i = 12``; ZN's step PI
has ``Ms = 2.566``); the ``T_r`` floors are measured by ``test_tr_floors_are_the_exact_model_delay_margin``.
The results pages' tables are the committed ``results/*/summary.md`` and ``regimes.md`` tables, and
the README's headline table is ``deadtime study headline``'s output for the committed
``results/agent_mode/regimes.json``.
"""

from __future__ import annotations

import importlib
import io
import itertools
import json
import re
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

from agents.cli import main
from agents.compressed import read_json

REPO = Path(__file__).resolve().parents[2]
README = (REPO / "README.md").read_text()
README_RESULTS = (REPO / "docs" / "exploration" / "v3_studies.md").read_text()  # the README links these tables
DOCS = REPO / "docs"
COMMAND_LINE = (DOCS / "command_line.md").read_text()
RESULTS = "\n".join((DOCS / page).read_text() for page in ("results.md", "results_history.md", "results_v0.md"))
# the agent-mode study: its method page and its exploration log
AGENT_MODE = "\n".join(path.read_text() for path in (DOCS / "agent_mode.md", *sorted((DOCS / "exploration").glob("*.md"))))
MODEL = '{"type": "fopdt", "gain": 2.5, "time_constant": 12, "dead_time": 4}'
INTERVAL = r"-?[\d.]+ \[-?[\d.]+, -?[\d.]+\]"


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        status = main(list(args))
    return status, out.getvalue(), err.getvalue()


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


def _committed() -> list[str]:
    """The text of every committed ``summary.md``, ``regimes.md``, ``information.md`` and ``fallback.md`` under ``results/``."""
    sweeps = REPO / "results"
    names = ("summary.md", "regimes.md", "information.md", "fallback.md")
    return [path.read_text() for name in names for path in sorted(sweeps.rglob(name))]


def _study(name: str):
    """A module of :mod:`agents.studies` (``deadtime study NAME``)."""
    return importlib.import_module(f"agents.studies.{name}")


def test_the_gap_decompositions_are_the_committed_per_plant_tables():
    """The tables of docs/exploration/own_plan.md that split a learner's difference to ``simc-pi`` by the rule's
    violating plants are ``deadtime study gap`` on the committed per-plant tables, and
    their parts add up to the summary's point estimate."""
    module = _study("gap")
    page = AGENT_MODE
    for sweep, group in (("spread_own_plan_noise10_time", "learned-plan-spread-10000"),
                         ("spread_own_plan_noise10_production", "learned-plan-cert-10000")):
        table = module.decompose(REPO / "results" / sweep, "PID-v3", group, "simc-pi")
        assert module.markdown(table) in page, sweep
        whole = table[-1]["difference per plant"]
        assert abs(table[0]["share of the mean difference"] + table[1]["share of the mean difference"] - whole) <= 1e-9 * (1 + abs(whole))
        assert f"{whole:.3g} [" in (REPO / "results" / sweep / "summary.md").read_text()


def test_the_fallback_tables_are_the_committed_pilot_rows():
    """docs/exploration/own_plan.md's fallback tables are ``deadtime study fallback``'s ``fallback.md``, made from
    the rows of its ``fallback.json``, of the sweeps' own fits (their models' sha256); the rows are
    consistent (each difference is the mean costs' difference and the mean of the per-seed differences,
    inside its interval and their range; the rule's share a fraction)."""
    module = _study("fallback")
    page = AGENT_MODE
    for regime, sweep, group in (("free", "spread_own_plan_noise10_time", "learned-plan-spread-10000"),
                                 ("priced", "spread_own_plan_noise10_production", "learned-plan-cert-10000")):
        folder = REPO / "results" / "spread_own_plan" / regime
        record = json.loads((folder / "fallback.json").read_text())
        seeds = [fit["seed"] for fit in record["fits"]]
        assert len(set(seeds)) == len(seeds) >= 10, regime
        for fit in record["fits"]:  # the sweep's own fits: the same model files
            manifest = REPO / "results" / sweep / "runs" / f"{group}-PID-v3-s{fit['seed']}" / "learned_rule.json"
            assert fit["sha256"] == read_json(manifest)["sha256"], manifest
        table = module.markdown(record["rows"], record["rule"], len(seeds))
        assert (folder / "fallback.md").read_text() == table + "\n" and table in page, regime
        learned = record["rows"][0]
        assert learned["policy"] == "learned design" and learned["rule_share"] == 0
        for k, row in enumerate(record["rows"]):
            by_seed = [fit["rows"][k]["difference"] for fit in record["fits"]]
            tolerance = 1e-9 * (1 + learned["mean_cost"])
            assert abs(row["difference"] - (row["mean_cost"] - learned["mean_cost"])) <= tolerance
            assert abs(row["difference"] - sum(by_seed) / len(by_seed)) <= tolerance
            assert row["seed_range"] == [min(by_seed), max(by_seed)] and 0 <= row["rule_share"] <= 1
            assert row["ci95"][0] <= row["difference"] <= row["ci95"][1]


def test_the_information_table_is_its_per_plant_costs():
    """``results/fixed_mode_v3/information.md``: the table ``deadtime study information`` makes of the
    committed per-plant costs (``information.json``)."""
    folder = REPO / "results" / "fixed_mode_v3"
    table = _study("information").table(json.loads((folder / "information.json").read_text()))
    assert table in _tables((folder / "information.md").read_text())


def test_the_results_tables_are_the_committed_sweep_summaries():
    """Every policy table of docs/results.md and docs/results_history.md is a table of a committed
    ``results/*/summary.md``, verbatim; every ``value [low, high]`` of their other tables (the
    overview, the regimes) is in one of them or in a committed ``results/*/regimes.md``
    (``deadtime regimes``) too."""
    summaries = _committed()
    committed = [table for summary in summaries for table in _tables(summary)]
    policy_tables = [t for t in _tables(RESULTS) if t.startswith("| policy | role |")]
    assert len(policy_tables) >= 3
    assert all(table in committed for table in policy_tables)
    quoted = [q for t in _tables(RESULTS) if not t.startswith("| policy | role |") for q in re.findall(INTERVAL, t)]
    assert len(quoted) >= 12
    assert all(any(q in summary for summary in summaries) for q in quoted), [q for q in quoted if not any(q in m for m in summaries)]


def test_every_interval_of_the_v3_study_pages_is_committed():
    """docs/agent_mode.md with its exploration log (docs/exploration/) and docs/results.md, prose and tables: every ``value [low, high]`` is in a
    committed ``results/*/summary.md`` or ``results/*/regimes.md``, as printed there (no rounding of
    one's own); the pooled test violation rates of the certified groups are
    ``deadtime study certificates``'s."""
    summaries = _committed()
    for page, text in (("agent_mode.md", AGENT_MODE), ("results.md", (DOCS / "results.md").read_text())):
        quoted = re.findall(INTERVAL, text)
        assert len(quoted) >= 15, page
        assert all(any(q in summary for summary in summaries) for q in quoted), [q for q in quoted if not any(q in m for m in summaries)]
    module = _study("certificates")
    certified = sorted(path for path in (REPO / "results").glob("certified_noise*") if path.is_dir())
    rates = [row.split(" | ")[6] for row in module.table(certified).splitlines()[2:]]
    page = AGENT_MODE
    assert len(rates) == 12 and all(rate in page for rate in rates), rates


def test_the_readme_headline_table_is_the_committed_regimes():
    """docs/exploration/v3_studies.md: the table is ``deadtime study headline``'s output for the committed
    ``results/agent_mode/regimes.json``, and each of its intervals is in the committed ``regimes.md``."""
    quoted = _readme_table_of(_study("headline").headline_table(), "agent_mode")
    assert len(quoted) >= 48


def test_the_readme_rl_tables_are_the_committed_regimes():
    """docs/exploration/v3_studies.md: the RL agent's table and what it does are ``deadtime study headline --rl``'s
    output for the committed ``results/rl_plan/regimes.json``; each interval is in a committed ``regimes.md``
    or ``summary.md`` (the procedures' costs are in the sweeps' summaries)."""
    module = _study("headline")
    results = _tables(README_RESULTS)
    costs, behaviour = module.rl_plan_table(), module.behaviour_table()
    assert costs in results and behaviour in results
    committed = _committed()
    quoted = re.findall(INTERVAL, costs)
    assert len(quoted) >= 48 and all(any(q in text for text in committed) for q in quoted), quoted


def test_the_readme_fixed_mode_table_is_the_committed_regimes():
    """docs/exploration/v3_studies.md: the fixed mode's table is ``deadtime study headline --fixed``'s output for
    the committed ``results/fixed_mode_v3/regimes.json``, and each of its intervals is in its ``regimes.md``."""
    expected = _study("headline").fixed_table()
    quoted = _readme_table_of(expected, "fixed_mode_v3")
    cells = [cell.strip() for line in expected.splitlines()[2:] for cell in line.strip("|").split("|")[1:]]
    assert len(quoted) == sum(cell != "-" for cell in cells) >= 22  # one interval in each filled cell


def test_the_readme_own_plan_table_is_the_committed_regimes():
    """docs/exploration/v3_studies.md: the table of the plan chosen for the learned design is ``deadtime study headline
    --own``'s output for the committed ``results/own_plan/regimes.json``; each interval is in its ``regimes.md``."""
    assert len(_readme_table_of(_study("headline").own_plan_table(), "own_plan")) >= 8


def _readme_table_of(expected: str, folder: str) -> list[str]:
    """Assert that the table ``expected`` is a table of README's Results and that each of its intervals is in
    ``results/FOLDER/regimes.md``; returns the intervals."""
    assert expected in _tables(README_RESULTS)
    regimes = (REPO / "results" / folder / "regimes.md").read_text()
    quoted = re.findall(INTERVAL, expected)
    assert all(q in regimes for q in quoted), [q for q in quoted if q not in regimes]
    return quoted


def _tables(text: str) -> list[str]:
    """The Markdown tables of ``text``: runs of consecutive lines that start with ``|``."""
    return ["\n".join(lines) for is_table, lines in itertools.groupby(text.splitlines(), lambda line: line.startswith("|"))
            if is_table]


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
    assert len(rows) >= 25 and [row for row in rows if row not in study] == []
