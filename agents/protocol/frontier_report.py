"""A frontier protocol's report: ``results.md`` and ``frontiers.png`` from its ``protocol_results.json``.

``results.md`` opens with the answer: one row per regime at 1% (:func:`answer_table`, the README's table).
Then one section per regime: the validation oracle and the best rule as shipped, the rule
families that cannot reach each declared risk level, and one row per comparison (each declared risk
level, then the best learned family at the shipped rule's risk): the families and knobs chosen on
validation, the test difference with its interval (seeds and plants random; the paired t over plants for a
one-model learner) and its Holm-adjusted interval, the percent of the rule's cost, the share of the
rule-to-oracle gap closed and both policies' test risk with its exact interval.  A level no rule family
reaches has no comparison; its row gives the learned family alone.  Last, each learned family's knob of
least validation cost at each level beside the best rule family's (the union over the seeds of the violating
plants in brackets).

``frontiers.png`` has one panel per regime: mean validation cost against risk (the share of plants on
which one model's design violates, per seed, averaged), each learned family a coloured curve over its
knob, each rule family a grey curve, the shipped rules (``s = 0``) as points, the declared risk levels as
vertical lines, the answer's pair (the row of :func:`answer_table`) ringed; the axes show risks up to 30%
and costs up to 1.5 times the most costly of the best families and the best rule as shipped.  One legend
serves every panel: a family has one colour in all of them.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

__all__ = ["answer_table", "frontier_markdown", "frontiers_figure", "write_frontier_report"]


def _percent(share: float) -> str:
    return f"{100 * share:.2f}%"


def _chosen(point: dict[str, Any]) -> str:
    return f"`{point['family']}` (s = {point['knob']:g}): {point['mean_cost']:.4g} at {_percent(point['risk'])}"


def _test_risk(policy: dict[str, Any]) -> str:
    low, high = policy["risk_interval"]
    return f"{_percent(policy['risk'])} [{100 * low:.2f}, {100 * high:.2f}]"


def _holm_intervals(matched: list[dict[str, Any]]) -> dict[tuple[str, str], list[float]]:
    """The Holm-adjusted interval of each pair (a pair answering several levels is counted once)."""
    return {(c["first_policy"], c["second_policy"]): c["holm_interval"] for c in matched if "holm_interval" in c}


def _comparison_row(level: str, c: dict[str, Any], holm: dict, test: dict[str, Any]) -> str:
    d, gap = c["difference"], c["gap_closed"]
    adjusted = holm.get((c["first_policy"], c["second_policy"]))
    held = "-" if adjusted is None else f"[{adjusted[0]:.3g}, {adjusted[1]:.3g}]"
    closed = "-" if gap["estimate"] is None else f"{100 * gap['estimate']:.0f}%" + (
        "" if gap["interval"] is None else f" [{100 * gap['interval'][0]:.0f}, {100 * gap['interval'][1]:.0f}]")
    return (f"| {level} | {_chosen(c['first'])} | {_chosen(c['second'])} | {d['estimate']:+.3g} [{d['low']:.3g}, "
            f"{d['high']:.3g}] | {held} | {c['percent_of_second']:+.1f}% | {closed} | "
            f"{_test_risk(test[c['first_policy']])}; {_test_risk(test[c['second_policy']])} |")


def _at_levels(regime: dict[str, Any]) -> list[str]:
    """Validation: each learned family's knob of least cost at each level (cost at its risk, per seed; the union
    over the seeds in brackets), then the best rule family at each level."""
    levels = list(regime["best"])
    lines = ["| validation | " + " | ".join(levels) + " |", "|---|" + "---|" * len(levels)]
    for family, entry in regime["frontiers"].items():
        if entry["kind"] != "learned":
            continue
        cells = []
        for level in levels:
            knob = regime["chosen"][family][level]
            i = None if knob is None else entry["knobs"].index(knob)
            cells.append("cannot reach" if i is None else f"{entry['mean_cost'][i]:.4g} at {_percent(entry['risk'][i])} "
                         f"({_percent(entry['risk_union'][i])}), s = {knob:g}")
        lines.append(f"| `{family}` | " + " | ".join(cells) + " |")
    rules = [regime["best"][level]["rule"] for level in levels]
    lines.append("| best rule family | " + " | ".join("none reaches it" if rule is None else _chosen(rule) for rule in rules) + " |")
    return lines + [""]


def _regime_section(name: str, regime: dict[str, Any]) -> list[str]:
    shipped, oracle = regime["shipped_rule"], regime["validation_oracle"]
    rules = [family for family, entry in regime["frontiers"].items() if entry["kind"] == "rule"]
    unreachable = {level: sum(family in rules for family in families) for level, families in regime["cannot_reach"].items()}
    lines = [f"## {name}", "",
             f"`{regime['env']}`" + (f" `{json.dumps(regime['env_kwargs'])}`" if regime["env_kwargs"] else "")
             + f": {regime['validation_plants']} validation plants, "
             f"{regime['test_plants']} test plants, learners with {len(regime['seeds'])} seeds.  Validation: the oracle "
             f"costs {oracle['mean_cost']:.4g}; the best rule as shipped is {_chosen(shipped)}.  Rule families that cannot "
             "reach the level on validation: " + ", ".join(f"{level} {count} of {len(rules)}" for level, count in unreachable.items())
             + ".", "",
             "| risk level | best learned family (validation) | best rule family (validation) | learned - rule on test [95%] "
             "| Holm-adjusted | percent | gap closed [95%] | test risk: learned; rule [95%] |",
             "|---|---|---|---:|---|---:|---:|---|"]
    holm, test = _holm_intervals(regime["matched"]), regime["test"]
    matched = {c["risk_level"]: c for c in regime["matched"] if c["kind"] == "matched risk"}
    rows = []
    for level, best in regime["best"].items():  # the declared levels in order, then the shipped rule's risk
        if level in matched:
            rows.append(_comparison_row(level, matched[level], holm, test))
        elif best["learned"] is None:
            rows.append(f"| {level} | no learned family reaches it | " + ("no rule family reaches it" if best["rule"] is None
                        else _chosen(best["rule"])) + " | - | - | - | - | - |")
        else:
            rows.append(f"| {level} | {_chosen(best['learned'])} | no rule family reaches it | - | - | - | - | - |")
    rows += [_comparison_row(f"the shipped rule's ({_percent(c['risk_level'])})", c, holm, test)
             for c in regime["matched"] if c["kind"] != "matched risk"]
    return lines + rows + ["", *_at_levels(regime)]


ANSWER_LEVEL = "1%"


def _answer(regime: dict[str, Any]) -> dict[str, Any] | None:
    """The regime's comparison at 1%, or at the least declared level with one (no rule family reaching 1%)."""
    matched = {c["risk_level"]: c for c in regime["matched"] if c["kind"] == "matched risk"}
    levels = list(regime["best"])
    later = [level for level in levels[levels.index(ANSWER_LEVEL):] if level in matched]
    return matched[later[0]] if later else None


def answer_table(results: dict[str, Any]) -> list[str]:
    """One row per regime: the best learned family against the best rule family at 1% (or the least level
    above at which a rule family is there), the test difference with its Holm-adjusted interval (seeds and plants
    random), its percent and the gap closed, both test risks."""
    lines = ["| structure and regime | risk level | best learned family | best rule family | learned - rule [Holm 95%] | "
             "percent; gap closed | test risk: learned; rule |", "|---|---|---|---|---:|---:|---|"]
    for name, regime in results["regimes"].items():
        c = _answer(regime)
        if c is None:
            lines.append(f"| {name} | - | no comparison: no rule family reaches a declared level | | | | |")
            continue
        d, gap, test = c["difference"], c["gap_closed"]["estimate"], regime["test"]
        low, high = _holm_intervals(regime["matched"])[(c["first_policy"], c["second_policy"])]
        level = c["risk_level"] if c["risk_level"] == ANSWER_LEVEL else f"{c['risk_level']} (no rule at {ANSWER_LEVEL})"
        lines.append(f"| {name} | {level} | `{c['first']['family']}` (s = {c['first']['knob']:g}) | `{c['second']['family']}` "
                     f"(s = {c['second']['knob']:g}) | {d['estimate']:+.3g} [{low:.3g}, {high:.3g}] | "
                     f"{c['percent_of_second']:+.1f}%; " + ("-" if gap is None else f"{100 * gap:.0f}%") + " | "
                     f"{_percent(test[c['first_policy']]['risk'])}; {_percent(test[c['second_policy']]['risk'])} |")
    return lines


def frontier_markdown(results: dict[str, Any], declared: int) -> str:
    """``results.md``: a heading with the protocol's identity and the Holm family, then one section per regime."""
    done = len(results["regimes"])
    lines = ["# Protocol v5: the learned families against the rule families at matched risk", "",
             f"`{results['protocol']}` (sha256 `{results['protocol_sha256'][:12]}`), run at commit `{str(results['commit'])[:7]}` "
             f"(code sha256 `{(results['code'] or {}).get('sha256', '')[:12]}`).  {done} of {declared} regimes tested; Holm "
             f"(alpha {results['alpha']}) over the {results['comparisons_in_holm_family']} comparisons of "
             + ("every regime." if done == declared else "the regimes tested so far, not final until every regime is in."),
             "", f"Intervals: {results['interval_method']}.  Test risks: the share of (seed, plant) episodes that violate, "
             "with the Clopper-Pearson interval; a refusal counts as violating.  Gap closed: (rule - learned) / (rule - "
             "oracle) of the test mean costs.", ""]
    lines += ["## The answer at 1%", "", "Per regime the comparison at 1%, or where no rule family reaches 1% on validation, at "
              "the least declared level a rule family reaches (a negative difference: the learned family is cheaper).", "",
              *answer_table(results), ""]
    for name, regime in results["regimes"].items():
        lines += _regime_section(name, regime)
    return "\n".join(lines)


LEARNED_ORDER = ("learned-rule", "selector", "sac", "ppo", "sac-lagrangian", "@0.005", "@0.01", "@0.02", "@0.05")


def _legend_name(family: str) -> str:
    """A learned family's name in the figure's one legend: a shipped learner's structure becomes ``<s>``
    (``learned-pid@0.01`` -> ``learned-<s>@0.01``), so that one colour means one family in every panel."""
    head, at, level = family.partition("@")
    return f"learned-<s>@{level}" if at and head.startswith("learned-") else family


def _colour(family: str) -> Any:
    import matplotlib.pyplot as plt

    name = _legend_name(family)
    key = name.removeprefix("learned-<s>")
    return plt.get_cmap("tab10").colors[LEARNED_ORDER.index(key) if key in LEARNED_ORDER else len(LEARNED_ORDER)]


def _panel(axes: Any, name: str, regime: dict[str, Any], levels: list[float]) -> None:
    for family, entry in regime["frontiers"].items():
        order = sorted(range(len(entry["knobs"])), key=lambda i: entry["knobs"][i])
        risk = [100 * entry["risk"][i] for i in order]
        cost = [entry["mean_cost"][i] for i in order]
        shipped = [i for i in order if entry["knobs"][i] == 0]
        if entry["kind"] == "rule":
            axes.plot(risk, cost, "-", color="0.8", linewidth=0.7, zorder=1)
            for i in shipped:
                axes.plot(100 * entry["risk"][i], entry["mean_cost"][i], ".", color="0.45", markersize=4, zorder=2)
        else:
            axes.plot(risk, cost, "-", marker=".", markersize=3, color=_colour(family), linewidth=1.2,
                      label=_legend_name(family), zorder=3)
    answer = _answer(regime)
    if answer is not None:
        for point in (answer["first"], answer["second"]):
            axes.plot(100 * point["risk"], point["mean_cost"], "o", markersize=8, markerfacecolor="none",
                      markeredgecolor="black", markeredgewidth=0.9, zorder=4)

    best = [point for chosen in regime["best"].values() for point in chosen.values() if point is not None]
    shown = [point["mean_cost"] for point in best] + [regime["shipped_rule"]["mean_cost"]]
    oracle = regime["validation_oracle"]["mean_cost"]
    axes.axhline(oracle, color="black", linestyle=":", linewidth=0.8, zorder=0)
    for level in levels:
        axes.axvline(100 * level, color="0.9", linewidth=0.8, zorder=0)
    axes.set_xscale("symlog", linthresh=1.0)
    axes.set_xlim(0.0, 30.0)
    axes.set_ylim(0.9 * oracle, 1.5 * max(shown))
    axes.set_title(name, fontsize=9)
    axes.tick_params(labelsize=7)


def frontiers_figure(results: dict[str, Any], path: Path) -> Path:
    """One panel per regime (two columns), the frontiers over the knob on the validation plants; one legend
    below them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from agents.files.writer import write_figure

    names = list(results["regimes"])
    rows = (len(names) + 1) // 2
    height = 2.9 * rows + 1.0
    figure, grid = plt.subplots(rows, 2, figsize=(9.0, height), squeeze=False)
    for axes, name in zip(grid.flat, names):
        _panel(axes, name, results["regimes"][name], results["risk_levels"])
    for axes in list(grid.flat)[len(names):]:
        axes.set_visible(False)
    for column in grid.T:
        shown = [axes for axes in column if axes.get_visible()]
        if shown:
            shown[-1].set_xlabel("risk: plants on which one model violates (%)", fontsize=8)
    for axes in grid[:, 0]:
        axes.set_ylabel("mean cost (validation)", fontsize=8)
    legend = {}
    for axes in grid.flat:
        handles, labels = axes.get_legend_handles_labels()
        legend.update(zip(labels, handles))
    figure.legend(list(legend.values()), list(legend), loc="lower center", ncol=5, fontsize=7, frameon=False)
    figure.suptitle("Cost against risk over each family's knob: learned families in colour, rule families grey, "
                    "shipped rules as dots, the oracle dotted,\nthe answer's pair (the README's table) ringed; "
                    "<s> is the regime's structure", fontsize=8)
    figure.tight_layout(rect=(0, 0.55 / height, 1, 1))  # the legend's two lines below the panels
    write_figure(path, figure, 120)
    plt.close(figure)
    return path


def write_frontier_report(results: dict[str, Any], out: Path, declared: int) -> list[Path]:
    """Write ``results.md`` and (with a regime tested) ``frontiers.png`` into ``out``; returns the paths."""
    from agents.files.writer import write_text

    written = [write_text(out / "results.md", frontier_markdown(results, declared))]
    if results["regimes"]:
        written.append(frontiers_figure(results, out / "frontiers.png"))
    return written
