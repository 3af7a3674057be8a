"""The calibration of the risk learners: requested against realized risk, per regime and per band of noise.

``deadtime pretrain --report [--structures PID,...] [--plants 2000] [--cached] [--labels DIR]`` plays the
shipped learners on their validation plants (:mod:`agents.risk.calibration`, cached in ``eval`` beside the
labels' folder ``DIR``, default ``runs/risk_learner``) and writes ``calibration.md`` and ``summary.json`` (default folder
``results/exploratory/risk_learner``).  Per band of noise it also gives the share of the labelled
plants on which no design of the structure is feasible: no design at any risk is below it.  A cell
most of whose plants the learner says unreachable at ``r`` (their band's floor above ``r``,
:meth:`agents.risk.model.RiskLearner.reachable`) is reported ``unreachable`` with the floor, not
counted as a miss; beside the count of misses, the count a learner calibrated exactly would show by
the check's sampling noise alone (:func:`agents.risk.calibration.expected_misses`).  Their
cost beside every rule family at matched risk is ``deadtime frontier``'s (docs/risk_learner.md).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from agents.risk.calibration import REGIMES, expected_misses, play_plants, regime_seeds, wilson
from agents.risk.train import RISKS

__all__ = ["BANDS", "matched_lines", "write_matched", "write_report"]

BANDS = (0.003, 0.01, 0.03, 0.1, 0.3)
"""The edges of the noise bands (``noise_std``) of the reliability table across regimes."""
LABELS = Path("runs/risk_learner/labels")
"""The default folder of the cached labels; the plays are cached in ``eval`` beside it."""


def _bands_path(labels: Path, structure: str, digest: str) -> Path:
    """The cached plays of the validation stream across regimes, in ``eval`` beside the labels' folder."""
    return labels.parent / "eval" / structure / f"bands-{digest}.json"


def _realized(rows: list[dict[str, Any]], risk: float) -> tuple[int, int]:
    return sum(not row["learner"][str(risk)][1] for row in rows), len(rows)


def _band_rows(config: Any, structure: str, learner: Any, digest: str, labels: Path) -> list[dict[str, Any]]:
    """The validation stream's plants, each replayed in its own regime (the same plant and noise as labelled)."""
    from agents.environments import make_env
    from agents.risk.labels import Regime, load_stream

    rows = []
    path = _bands_path(labels, structure, digest)
    if path.is_file():
        return json.loads(path.read_text())
    from agents.risk.calibration import play_plant

    for record in load_stream(labels, structure, "validation")[: config.validation_plants]:
        regime = Regime(record["noise_std"], record["production"], record["quantization"])
        env = make_env(config.env_id(structure), regime.env_kwargs(config.env_kwargs))
        row = play_plant(env, record["seed"], learner)
        env.close()
        rows.append({**row, "noise_std": record["noise_std"], "no_design": record.get("boundary_action") is None})
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(rows))
    return rows


def _verdict(row: dict[str, Any], risk: float) -> str:
    """``yes``, ``NO`` or, where most plants are unreachable at ``risk``, ``unreachable: floor p0``."""
    if row.get("unreachable", 0.0) > 0.5:
        return f"unreachable: floor {row['floor']:.4f}"
    return "yes" if 0.5 * risk <= row["realized"] <= 1.5 * risk else "NO"


def _count_line(summary: dict[str, Any]) -> str:
    """How many cells are within, missed and unreachable, and the misses expected of an exactly calibrated learner."""
    verdicts, reached = [], []
    for regimes in summary.values():
        for found in regimes["regimes"].values():
            for risk, row in found.items():
                verdicts.append(_verdict(row, float(risk)))
                if not verdicts[-1].startswith("unreachable"):
                    reached.append((row["plants"], float(risk)))
    within, unreachable = verdicts.count("yes"), sum(v.startswith("unreachable") for v in verdicts)
    return (f"{within} of {len(verdicts)} cells within [0.5 r, 1.5 r], {len(verdicts) - within - unreachable} outside, "
            f"{unreachable} unreachable (the floor above r).  A learner calibrated exactly would fall outside in "
            f"{expected_misses(reached):.1f} of the {len(reached)} reachable cells by the check's sampling noise alone "
            "(binomial, exact).")


def _calibration_lines(summary: dict[str, Any]) -> list[str]:
    lines = ["| structure | regime | plants | requested r | violating plants | realized | 95% interval | within [0.5 r, 1.5 r] | mean cost |",
             "|---|---|---:|---:|---:|---:|---|---|---:|"]
    for structure, regimes in summary.items():
        for regime, found in regimes["regimes"].items():
            for risk, row in found.items():
                r = float(risk)
                lines.append(f"| {structure} | {regime} | {row['plants']} | {r:.3g} | {row['violations']} | {row['realized']:.4f} | "
                             f"[{row['interval'][0]:.4f}, {row['interval'][1]:.4f}] | {_verdict(row, r)} | {row['mean_cost']:.3f} |")
    return lines


def _band_lines(summary: dict[str, Any]) -> list[str]:
    lines = ["| structure | noise_std band | plants | no feasible design | " + " | ".join(f"realized at {r:g}" for r in RISKS) + " |",
             "|---|---|---:|---:|" + "---:|" * len(RISKS)]
    for structure, regimes in summary.items():
        for band, row in regimes["bands"].items():
            lines.append(f"| {structure} | {band} | {row['plants']} | {row['no_design'] / max(row['plants'], 1):.4f} | "
                         + " | ".join(f"{row[str(r)]:.4f}" for r in RISKS) + " |")
    return lines


def _cell(row: dict[str, Any] | None, knob: bool = True) -> str:
    if row is None:
        return "cannot reach"
    name = f"{row['family']} (s = {row['knob']:g}): " if knob else ""
    return f"{name}{row['mean_cost']:.3f} ({100 * row['risk']:.2f}%)"


def matched_lines(frontiers: list[dict[str, Any]]) -> list[str]:
    """Per ``deadtime frontier`` result (its ``frontier.json``) and declared risk level: the shipped learner at
    that risk as a user runs it (``learned-<structure>@<r>``, ``s = 0``), the best rule family at the level, every
    other learned family at its knob chosen for the level, and the oracle."""
    lines = ["| environment, regime | r | shipped learner at r, s = 0: cost (risk) | best rule family at r | "
             "other learned families at r | oracle |", "|---|---:|---|---|---|---:|"]
    for result in frontiers:
        rows = {(row["family"], row["knob"]): row for row in result["rows"]}
        structure = result["env_id"].split("/")[1].split("-")[0].lower()
        regime = json.dumps(result["env_kwargs"] or {}, sort_keys=True)
        learned = [f for f, kinds in {row["family"]: row["kind"] for row in result["rows"]}.items()
                   if kinds != "rule" and not f.startswith(f"learned-{structure}@")]
        for level, risk in zip(result["best"], result["risk_levels"]):
            own = rows.get((f"learned-{structure}@{risk:g}", 0.0))
            others = []
            for family in learned:
                knob = result["chosen"][family][level]
                others.append(f"{family}: cannot reach" if knob is None else _cell(rows[(family, knob)]))
            lines.append(f"| {result['env_id']} {regime} | {level} | {_cell(own, knob=False) if own else '-'} | "
                         f"{_cell(result['best'][level]['rule'])} | {'; '.join(others) or '-'} | {result['oracle']['mean_cost']:.3f} |")
    return lines


def write_matched(frontier_dirs: list[Path], out: Path) -> Path:
    """``out/comparison.md``: :func:`matched_lines` of the ``frontier.json`` in each of ``frontier_dirs``."""
    results = [json.loads((folder / "frontier.json").read_text()) for folder in frontier_dirs]
    text = ["# The shipped learners beside every rule family and the other learners, at matched risk", "",
            "Written by `deadtime pretrain --report --frontiers DIR` from `deadtime frontier`'s results (docs/risk_learner.md):",
            "each policy's mean cost (share of violating plants, per seed) on the frontier's validation plants; a family's",
            "knob is its least costly within the level, a rule family that reaches no level is `cannot reach`.", "",
            *matched_lines(results), ""]
    out.mkdir(parents=True, exist_ok=True)
    (out / "comparison.md").write_text("\n".join(text))
    return out / "comparison.md"


def write_report(config_path: str, structures: list[str], plants: int, out: Path, models: Path | None = None,
                 cached: bool = False, labels: Path = LABELS) -> Path:
    """Play the learners of ``models`` (default: the shipped ones) on ``plants`` validation plants per structure and
    regime (only the plants played so far where ``cached``) and write the tables to ``out``: its path.  The labels
    are read from ``labels``, the plays cached in ``eval`` beside it."""
    from agents.risk.config import load_config
    from agents.risk.pretrained import PRETRAINED_DIR, load_learner

    config = load_config(config_path)
    summary: dict[str, Any] = {}
    for structure in structures:
        learner, manifest, _ = load_learner(structure, models or PRETRAINED_DIR)
        entry = {"model": manifest["model"], "conformal_bands": manifest["bands"], "sha256": manifest["sha256"],
                 "training_plants": manifest["config"]["training_plants"], "regimes": {}, "bands": {}}
        for regime, kwargs in REGIMES.items():
            seeds = regime_seeds(config.validation_entropy, structure, regime, plants)
            stream = f"{regime}-{manifest['sha256'][:12]}"
            rows = play_plants(labels.parent / "eval", config.env_id(structure), {**config.env_kwargs, **kwargs}, structure, stream, seeds, learner,
                               cached=cached)
            if not rows:
                continue
            entry["regimes"][regime] = {}
            for risk in RISKS:
                k, n = _realized(rows, risk)
                unreached = [row for row in rows if not row.get("reached", {}).get(str(risk), True)]
                entry["regimes"][regime][str(risk)] = {"plants": n, "violations": k, "realized": k / n, "interval": list(wilson(k, n)),
                                                      "mean_cost": float(np.mean([row["learner"][str(risk)][0] for row in rows])),
                                                      "unreachable": len(unreached) / n,
                                                      "floor": float(np.mean([row["floor"] for row in unreached])) if unreached else 0.0}
        band_path = _bands_path(labels, structure, manifest["sha256"][:12])
        band_rows = _band_rows(config, structure, learner, manifest["sha256"][:12], labels) if band_path.is_file() or not cached else []
        noise = np.array([row["noise_std"] for row in band_rows])
        for low, high in zip(BANDS[:-1], BANDS[1:]) if band_rows else ():
            inside = [row for row, v in zip(band_rows, noise) if low <= v < high or (high == BANDS[-1] and v == high)]
            entry["bands"][f"[{low:g}, {high:g})"] = {"plants": len(inside), "no_design": sum(row["no_design"] for row in inside),
                                                      **{str(r): _realized(inside, r)[0] / max(len(inside), 1) for r in RISKS}}
        summary[structure] = entry
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").write_text(json.dumps({"calibration": summary}, indent=1) + "\n")
    text = ["# The risk-conditioned learners: requested against realized risk", "",
            "Written by `deadtime pretrain --report` (docs/risk_learner.md).  Validation plants of the config's own",
            "stream; a design violates when its loop on the true plant breaks a constraint or there is no design.", "",
            "## Per regime", "", _count_line(summary), "", *_calibration_lines(summary), "",
            "## Per noise band (the validation stream across regimes, each plant in its own regime)", "", *_band_lines(summary), ""]
    (out / "calibration.md").write_text("\n".join(text))
    return out
