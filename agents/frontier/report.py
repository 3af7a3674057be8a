"""The outputs of ``deadtime frontier``: ``frontier.md``, ``frontier.csv``, ``frontier.json`` and ``frontier.png``.

The table has one row per family and knob (mean cost, risk per seed averaged, union risk), then per
risk level each family's chosen knob ("cannot reach" where none reaches it) and the best rule and
learned families.  The plot is mean cost against risk, one curve per family over its knob, the
shipped policy (``s = 0``) marked, the declared risk levels drawn.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from agents.files.writer import write_figure

__all__ = ["CSV_FIELDS", "frontier_markdown", "frontier_plot", "write_frontier"]

CSV_FIELDS = ("family", "kind", "knob", "mean_cost", "risk", "risk_union", "seeds", "plants")


def _percent(share: float) -> str:
    return f"{100 * share:.2f}%"


def frontier_markdown(result: dict[str, Any]) -> str:
    """The frontier table and the choices per risk level, as Markdown."""
    lines = [f"# Frontier of {result['env_id']} on {result['n']} validation plants (seed {result['seed']})", "",
             "| family | kind | knob s | mean cost | risk (per seed) | risk (union) | seeds |", "|---|---|---:|---:|---:|---:|---:|"]
    for row in result["rows"]:
        shipped = " (shipped)" if row["knob"] == 0 else ""
        lines.append(f"| {row['family']} | {row['kind']} | {row['knob']:g}{shipped} | {row['mean_cost']:.4g} | "
                     f"{_percent(row['risk'])} | {_percent(row['risk_union'])} | {row['seeds']} |")
    oracle = result["oracle"]
    lines += ["", f"Oracle (per-plant optimum of the structure's parameter, on the identified data): mean cost "
              f"{oracle['mean_cost']:.4g}, risk {_percent(oracle['risk'])}.", "",
              "## The knob of least validation cost at each risk level", "",
              "| family | " + " | ".join(f"r = {level}" for level in result["chosen"][next(iter(result["chosen"]))]) + " |",
              "|---|" + "---:|" * len(result["risk_levels"])]
    for family, chosen in result["chosen"].items():
        cells = ["cannot reach" if knob is None else f"s = {knob:g}" for knob in chosen.values()]
        lines.append(f"| {family} | " + " | ".join(cells) + " |")
    lines += ["", "| risk level | best rule family | best learned family | learned - rule [95%, seeds and plants random] |",
              "|---|---|---|---|"]
    for level, best in result["best"].items():
        cells = ["-" if b is None else f"{b['family']} (s = {b['knob']:g}): {b['mean_cost']:.4g} at {_percent(b['risk'])}"
                 for b in (best["rule"], best["learned"])]
        d = best.get("difference")
        cells.append("-" if d is None else f"{d['estimate']:.3g} [{d['low']:.3g}, {d['high']:.3g}]")
        lines.append(f"| {level} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def frontier_plot(result: dict[str, Any], path: Path) -> Path:
    """Mean cost against risk (per seed), one curve per family over its knob, ``s = 0`` marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7.0, 4.5))
    families = dict.fromkeys(row["family"] for row in result["rows"])
    for family in families:
        rows = sorted((row for row in result["rows"] if row["family"] == family), key=lambda row: row["knob"])
        risk = [100 * row["risk"] for row in rows]
        cost = [row["mean_cost"] for row in rows]
        style = "-" if rows[0]["kind"] == "rule" else "--"
        (line,) = axes.plot(risk, cost, style, marker=".", label=f"{family} ({rows[0]['kind']})")
        shipped = next(row for row in rows if row["knob"] == 0)
        axes.plot(100 * shipped["risk"], shipped["mean_cost"], "o", color=line.get_color(), markersize=8, markerfacecolor="none")
    for level in result["risk_levels"]:
        axes.axvline(100 * level, color="0.8", linewidth=0.8, zorder=0)
    axes.set_xscale("symlog", linthresh=1.0)
    axes.set_xlim(left=0.0)
    axes.set_xlabel("risk: plants on which one model's design violates (%, per seed, averaged)")
    axes.set_ylabel("mean cost")
    axes.set_title(f"{result['env_id']}: cost against risk over the knob (circle: s = 0)")
    axes.legend(fontsize=7)
    figure.tight_layout()
    write_figure(path, figure, 120)
    plt.close(figure)
    return path


def write_frontier(out: Path, result: dict[str, Any], plots: bool = True) -> list[Path]:
    """Write the frontier's table (Markdown, CSV, JSON) and plot into ``out`` (created); returns the paths."""
    from agents.files.writer import write_csv, write_text

    out.mkdir(parents=True, exist_ok=True)
    written = [write_text(out / "frontier.md", frontier_markdown(result)),
               write_csv(out / "frontier.csv", [CSV_FIELDS, *([row[f] for f in CSV_FIELDS] for row in result["rows"])]),
               write_text(out / "frontier.json", json.dumps(result, indent=2) + "\n")]
    if plots:
        written.append(frontier_plot(result, out / "frontier.png"))
    return written
