"""The tables of ``results/risk_learner/``: calibration (requested against realized risk) and cost beside the rule families.

``deadtime pretrain --report [--structures PID,...] [--plants 2000] [--cached]`` plays the
shipped learners on their validation plants (:mod:`agents.risk.calibration`, cached in
``runs/risk_learner/eval``) and writes ``results/risk_learner/calibration.md``, ``comparison.md`` and
``summary.json``.  The rule families' rows are read from the cache where a run of the rules has
written them (``rules-<regime>`` streams of the same plants: the first ``--rule-plants``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from agents.risk.calibration import REGIMES, frontier_choice, play_plants, regime_seeds, wilson
from agents.risk.train import RISKS

__all__ = ["BANDS", "KNOBS", "write_report"]

BANDS = (0.003, 0.01, 0.03, 0.1, 0.3)
"""The edges of the noise bands (``noise_std``) of the reliability table across regimes."""
KNOBS = (-0.5, -0.25, 0.0, 0.25, 0.5, 1.0, 1.5)
"""The rule families' knob grid (:data:`agents.frontier.frontier.DEFAULT_KNOBS` without its extremes)."""
EVAL = Path("runs/risk_learner/eval")


def _realized(rows: list[dict[str, Any]], risk: float) -> tuple[int, int]:
    return sum(not row["learner"][str(risk)][1] for row in rows), len(rows)


def _band_rows(config: Any, structure: str, learner: Any, digest: str) -> list[dict[str, Any]]:
    """The validation stream's plants, each replayed in its own regime (the same plant and noise as labelled)."""
    from agents.environments import make_env
    from agents.risk.labels import Regime, load_stream

    rows = []
    path = EVAL / structure / f"bands-{digest}.json"
    if path.is_file():
        return json.loads(path.read_text())
    from agents.risk.calibration import _play_one

    for record in load_stream(Path("runs/risk_learner/labels"), structure, "validation")[: config.validation_plants]:
        regime = Regime(record["noise_std"], record["production"], record["quantization"])
        env = make_env(config.env_id(structure), regime.env_kwargs(config.env_kwargs))
        row = _play_one(env, record["seed"], learner, [], ())
        env.close()
        rows.append({**row, "noise_std": record["noise_std"]})
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(rows))
    return rows


def _calibration_lines(summary: dict[str, Any]) -> list[str]:
    lines = ["| structure | regime | plants | requested r | violating plants | realized | 95% interval | within [0.5 r, 1.5 r] | mean cost |",
             "|---|---|---:|---:|---:|---:|---|---|---:|"]
    for structure, regimes in summary.items():
        for regime, found in regimes["regimes"].items():
            for risk, row in found.items():
                r = float(risk)
                lines.append(f"| {structure} | {regime} | {row['plants']} | {r:.3g} | {row['violations']} | {row['realized']:.4f} | "
                             f"[{row['interval'][0]:.4f}, {row['interval'][1]:.4f}] | "
                             f"{'yes' if 0.5 * r <= row['realized'] <= 1.5 * r else 'NO'} | {row['mean_cost']:.3f} |")
    return lines


def _band_lines(summary: dict[str, Any]) -> list[str]:
    lines = ["| structure | noise_std band | plants | " + " | ".join(f"realized at {r:g}" for r in RISKS) + " |",
             "|---|---|---:|" + "---:|" * len(RISKS)]
    for structure, regimes in summary.items():
        for band, row in regimes["bands"].items():
            lines.append(f"| {structure} | {band} | {row['plants']} | " + " | ".join(f"{row[str(r)]:.4f}" for r in RISKS) + " |")
    return lines


def _comparison(rows: list[dict[str, Any]], rule_rows: list[dict[str, Any]], families: list[str]) -> dict[str, Any]:
    """Per risk: the learner's mean cost and risk on the plants the rules were played on, every family's choice."""
    by_seed = {row["seed"]: row for row in rows}
    rule_rows = [row for row in rule_rows if row["seed"] in by_seed]  # the plants both were played on
    own = [by_seed[row["seed"]] for row in rule_rows]
    n = len(rule_rows)
    found = {}
    for risk in RISKS:
        cost = float(np.mean([row["learner"][str(risk)][0] for row in own]))
        share = float(np.mean([not row["learner"][str(risk)][1] for row in own]))
        chosen = {family: frontier_choice(rule_rows, family, KNOBS, risk) for family in families}
        reached = {f: c for f, c in chosen.items() if c is not None}
        best = min(reached, key=lambda f: reached[f][1]) if reached else None
        found[str(risk)] = {"plants": n, "learner_cost": cost, "learner_risk": share, "best_family": best,
                            "best": None if best is None else list(reached[best]),
                            "beaten_by": sorted(f for f, c in reached.items() if c[1] < cost),
                            "unreached": sorted(f for f, c in chosen.items() if c is None), "families": len(families)}
    return found


def _comparison_lines(comparisons: dict[str, Any]) -> list[str]:
    lines = ["| structure | regime | plants | r | learner: mean cost (risk) | best rule family at r: knob, mean cost (risk) | "
             "learner - best | families cheaper than the learner | families that cannot reach r |",
             "|---|---|---:|---:|---|---|---:|---|---:|"]
    for (structure, regime), found in comparisons.items():
        for risk, row in found.items():
            best = row["best"]
            best_text = "none reaches r" if best is None else f"{row['best_family']} @ {best[0]:g}: {best[1]:.3f} ({best[2]:.3f})"
            gap = "" if best is None else f"{row['learner_cost'] - best[1]:+.3f}"
            lines.append(f"| {structure} | {regime} | {row['plants']} | {float(risk):g} | {row['learner_cost']:.3f} ({row['learner_risk']:.3f}) | "
                         f"{best_text} | {gap} | {', '.join(row['beaten_by']) or 'none'} | {len(row['unreached'])} of {row['families']} |")
    return lines


def write_report(config_path: str, structures: list[str], plants: int, out: Path, models: Path | None = None,
                 cached: bool = False) -> Path:
    """Play the learners of ``models`` (default: the shipped ones) on ``plants`` validation plants per structure and
    regime (only the plants played so far where ``cached``) and write the tables to ``out``: its path."""
    from agents.evaluation.policies import applicable_rules
    from agents.risk.config import load_config
    from agents.risk.pretrained import PRETRAINED_DIR, load_learner

    config = load_config(config_path)
    summary: dict[str, Any] = {}
    comparisons: dict[tuple[str, str], Any] = {}
    for structure in structures:
        learner, manifest, _ = load_learner(structure, models or PRETRAINED_DIR)
        entry = {"model": manifest["model"], "bands": manifest["bands"], "sha256": manifest["sha256"],
                 "training_plants": manifest["config"]["training_plants"], "regimes": {}, "bands": {}}
        for regime, kwargs in REGIMES.items():
            seeds = regime_seeds(config.validation_entropy, structure, regime, plants)
            stream = f"{regime}-{manifest['sha256'][:12]}"
            rows = play_plants(EVAL, config.env_id(structure), {**config.env_kwargs, **kwargs}, structure, stream, seeds, learner,
                               cached=cached)
            if not rows:
                continue
            entry["regimes"][regime] = {}
            for risk in RISKS:
                k, n = _realized(rows, risk)
                entry["regimes"][regime][str(risk)] = {"plants": n, "violations": k, "realized": k / n, "interval": list(wilson(k, n)),
                                                      "mean_cost": float(np.mean([row["learner"][str(risk)][0] for row in rows]))}
            rule_path = EVAL / structure
            rule_rows = []
            for path in sorted(rule_path.glob(f"rules-{regime}-*.json")):
                rule_rows += json.loads(path.read_text())
            if rule_rows:
                families = applicable_rules(structure.lower())
                comparisons[(structure, regime)] = _comparison(rows, rule_rows, families)
        band_path = EVAL / structure / f"bands-{manifest['sha256'][:12]}.json"
        band_rows = _band_rows(config, structure, learner, manifest["sha256"][:12]) if band_path.is_file() or not cached else []
        noise = np.array([row["noise_std"] for row in band_rows])
        for low, high in zip(BANDS[:-1], BANDS[1:]) if band_rows else ():
            inside = [row for row, v in zip(band_rows, noise) if low <= v < high or (high == BANDS[-1] and v == high)]
            entry["bands"][f"[{low:g}, {high:g})"] = {"plants": len(inside),
                                                      **{str(r): _realized(inside, r)[0] / max(len(inside), 1) for r in RISKS}}
        summary[structure] = entry
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").write_text(json.dumps({"calibration": summary, "comparison": {
        f"{s} {r}": v for (s, r), v in comparisons.items()}}, indent=1) + "\n")
    text = ["# The risk-conditioned learners: requested against realized risk", "",
            "Written by `deadtime pretrain --report` (docs/risk_learner.md).  Validation plants of the config's own",
            "stream; a design violates when its loop on the true plant breaks a constraint or there is no design.", "",
            "## Per regime", "", *_calibration_lines(summary), "",
            "## Per noise band (the validation stream across regimes, each plant in its own regime)", "", *_band_lines(summary), ""]
    (out / "calibration.md").write_text("\n".join(text))
    if comparisons:
        text = ["# The learners beside every rule family at matched risk", "",
                "Written by `deadtime pretrain --report`.  The same validation plants (the first of the calibration plants),",
                f"each rule family `RULE@S` over the knob grid {list(KNOBS)}, its knob of least mean cost among those whose share",
                "of violating plants is at most r (docs/frontier.md); the learner at r.  Paired: every design on the same identification.", "",
                *_comparison_lines(comparisons), ""]
        (out / "comparison.md").write_text("\n".join(text))
    return out
