"""The headline table of README.md ("Results"), generated from the committed agent-mode study.

    python tests/tools/headline_table.py [sweeps/agent_mode/regimes.json]

prints the Markdown table: one row per regime of ``sweeps/agent_mode/regimes.json`` (written by
``deadtime regimes``), the structure, noise and production price, the oracle's and the best rule's
mean cost, the learned plan's with its violation rate, and the same for the learned plan with a
certified margin (``learned-plan-cert``) with its paired difference to the best rule.
Intervals are 95% bootstrap intervals as in ``regimes.md``, formatted the same way (3 significant
digits).  ``tests/unit/test_docs_numbers.py`` holds the README's table equal to this output.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

REGIMES = Path(__file__).resolve().parents[2] / "sweeps" / "agent_mode" / "regimes.json"
STRUCTURES = ("PID", "FPPI", "MSP")
HEADER = ("| structure | noise | production price | oracle | best rule | learned plan | its violations "
          "| certified learned plan | its violations | certified - best rule |")


def _cell(values: list[float]) -> str:
    """``mean [low, high]`` as ``deadtime regimes`` writes it (``agents/sweeps/regimes.py``)."""
    return f"{values[0]:.3g} [{values[1]:.3g}, {values[2]:.3g}]"


def headline_table(path: Path = REGIMES) -> str:
    """The README's headline table, from a ``regimes.json``."""
    regimes = json.loads(path.read_text())["regimes"]

    def order(regime: dict) -> tuple:
        kwargs = regime["env_kwargs"]
        return (STRUCTURES.index(regime["env"].split("-")[0]), kwargs["noise_std"], kwargs["weights"]["production"])

    lines = [HEADER, "|" + "---|" * HEADER.count(" | ") + "---|"]
    for regime in sorted(regimes, key=order):
        kwargs, best = regime["env_kwargs"], regime["best_rule"]
        costs = regime["mean_cost"]
        certified = regime["agents_to_rules"]["learned-plan-cert"]["best_rule"]
        rates = regime["violation_rate"]
        lines.append(" | ".join((
            f"| `{regime['env'].split('-')[0]}`", f"{100 * kwargs['noise_std']:g}%", f"{kwargs['weights']['production']:g}",
            _cell(costs["oracle"]), f"`{best}` {_cell(costs[best])}", _cell(costs["learned-plan"]),
            f"{100 * rates['learned-plan']:.1f}%", _cell(costs["learned-plan-cert"]), f"{100 * rates['learned-plan-cert']:.1f}%",
            f"{_cell(certified)} |",
        )))
    return "\n".join(lines)


if __name__ == "__main__":
    print(headline_table(Path(sys.argv[1]) if len(sys.argv) > 1 else REGIMES))
