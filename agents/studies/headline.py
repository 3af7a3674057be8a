"""The headline table of README.md ("Results"), generated from the committed agent-mode study.

    deadtime study headline [results/agent_mode/regimes.json]
    deadtime study headline --rl [results/rl_plan/regimes.json]
    deadtime study headline --fixed [results/fixed_mode_v3/regimes.json]
    deadtime study headline --own [results/own_plan/regimes.json]

prints the Markdown table: one row per regime of ``results/agent_mode/regimes.json`` (written by
``deadtime regimes``), the structure, noise and production price, the oracle's and the best rule's
mean cost, the learned plan's with its violation rate, and the same for the learned plan with a
certified margin (``learned-plan-cert``) with its paired difference to the best rule.
With ``--rl``, the two tables of the RL agent in plan mode from ``results/rl_plan/regimes.json``
(:func:`rl_plan_table`: its costs and paired differences; :func:`behaviour_table`: what it and the
certified learned plan do on validation plants).
With ``--fixed``, the fixed mode's table from ``results/fixed_mode_v3/regimes.json`` (:func:`fixed_table`:
the paired differences of the learned designs of :data:`FIXED_POLICIES` to the best rule, each with its
violation rate).
With ``--own``, the certified learned plan with the plan chosen for the learned design from
``results/own_plan/regimes.json`` (:func:`own_plan_table`: against the best rule and against the same
learner on the base rule's plan).
Intervals are 95% bootstrap intervals as in ``regimes.md``, formatted the same way (3 significant
digits).  ``tests/unit/test_docs_numbers.py`` holds the README's tables equal to this output.
"""

from __future__ import annotations

from pathlib import Path

from agents.compressed import exists, read_json

RESULTS = Path(__file__).resolve().parents[2] / "results"
REGIMES = RESULTS / "agent_mode" / "regimes.json"
RL_REGIMES = RESULTS / "rl_plan" / "regimes.json"
FIXED_REGIMES = RESULTS / "fixed_mode_v3" / "regimes.json"
OWN_REGIMES = RESULTS / "own_plan" / "regimes.json"
STRUCTURES = ("PID", "FPPI", "MSP")
HEADER = ("| structure | noise | production price | oracle | best rule | learned plan | its violations "
          "| certified learned plan | its violations | certified - best rule |")


def _cell(values: list[float]) -> str:
    """``mean [low, high]`` as ``deadtime regimes`` writes it (``agents/sweeps/regimes.py``)."""
    return f"{values[0]:.3g} [{values[1]:.3g}, {values[2]:.3g}]"


def _order(regime: dict) -> tuple:
    kwargs = regime["env_kwargs"]
    return (STRUCTURES.index(regime["env"].split("-")[0]), kwargs["noise_std"], kwargs["weights"]["production"])


def _head(header: str) -> list[str]:
    return [header, "|" + "---|" * header.count(" | ") + "---|"]


def _regimes(path: Path) -> list[dict]:
    """The regimes of a ``regimes.json``, by structure, noise and production price."""
    return sorted(read_json(path)["regimes"], key=_order)


def _structure(regime: dict) -> str:
    return f"`{regime['env'].split('-')[0]}`"


def _differences(regime: dict, first: str) -> dict[str, list[float]]:
    """The ``--compare`` differences ``first - B`` of a regime, by ``B``."""
    return {d["second"]: d["estimate"] for d in regime["differences"] if d["first"] == first}


def _regime_cells(regime: dict) -> tuple[str, str, str]:
    """The structure, the noise level and the production price of a regime's row."""
    kwargs = regime["env_kwargs"]
    return _structure(regime), f"{100 * kwargs['noise_std']:g}%", f"{kwargs['weights']['production']:g}"


def headline_table(path: Path = REGIMES) -> str:
    """The README's headline table, from a ``regimes.json``."""
    lines = _head(HEADER)
    for regime in _regimes(path):
        best, costs = regime["best_rule"], regime["mean_cost"]
        certified = regime["agents_to_rules"]["learned-plan-cert"]["best_rule"]
        rates = regime["violation_rate"]
        lines.append(" | ".join((
            "| " + " | ".join(_regime_cells(regime)),
            _cell(costs["oracle"]), f"`{best}` {_cell(costs[best])}", _cell(costs["learned-plan"]),
            f"{100 * rates['learned-plan']:.1f}%", _cell(costs["learned-plan-cert"]), f"{100 * rates['learned-plan-cert']:.1f}%",
            f"{_cell(certified)} |",
        )))
    return "\n".join(lines)


RL_HEADER = ("| structure | noise | production price | best rule | `plan-best` | learned plan | SAC plan | its violations "
             "| SAC plan - best rule | SAC plan - `plan-best` | SAC plan - `plan-1-1` | SAC plan - learned plan |")


def rl_plan_table(path: Path = RL_REGIMES) -> str:
    """SAC in plan mode (``sac-plan``) against the best rule, the best single plan, the fixed procedure and
    the learned plan, one row per regime of a ``regimes.json`` made with ``--compare sac-plan,...``."""
    lines = _head(RL_HEADER)
    for regime in _regimes(path):
        best, costs = regime["best_rule"], regime["mean_cost"]
        differences = _differences(regime, "sac-plan")
        lines.append(" | ".join((
            "| " + " | ".join(_regime_cells(regime)),
            f"`{best}` {_cell(costs[best])}", _cell(costs["plan-best"]), _cell(costs["learned-plan"]), _cell(costs["sac-plan"]),
            f"{100 * regime['violation_rate']['sac-plan']:.1f}%", _cell(regime["agents_to_rules"]["sac-plan"]["best_rule"]),
            _cell(differences["plan-best"]), _cell(differences["plan-1-1"]), f"{_cell(differences['learned-plan'])} |",
        )))
    return "\n".join(lines)


BEHAVIOUR_HEADER = ("| structure | noise | production price | policy | closed-loop step amplitude | second experiment amplitude "
                    "| experiment time (`T_ar`) | design action |")
BEHAVIOUR_NAMES = {"sac-plan": "SAC plan", "learned-plan-cert": "certified learned plan"}


def behaviour_table(path: Path = RL_REGIMES) -> str:
    """The plans and designs of SAC in plan mode and of the (certified) learned plan on 50 validation plants:
    quartiles over seeds and plants, as ``deadtime regimes --behaviour`` records them."""
    lines = _head(BEHAVIOUR_HEADER)

    def quartiles(values: list[float]) -> str:
        return ", ".join(f"{v:.2g}" for v in values)

    for regime in _regimes(path):
        for label, name in BEHAVIOUR_NAMES.items():
            found = regime["behaviour"][label]
            first, second = found["plan_amplitude_quartiles"]
            lines.append(" | ".join((
                "| " + " | ".join(_regime_cells(regime)),
                name, quartiles(first), quartiles(second), f"{found['experiment_time']:.1f}",
                f"{', '.join(f'{v:+.2f}' for v in found['design_action_quartiles'])} |",
            )))
    return "\n".join(lines)


FIXED_POLICIES = {"learned-fixed": "learned design", "learned-fixed-cert-3000": "certified, 3000 plants",
                  "learned-fixed-cert-10000": "certified, 10000 plants",
                  "learned-fixed-spread-10000": "certified, spread margin",
                  "learned-fixed-spread-3000": "certified, spread margin",
                  "learned-fixed-robustness": "learned, robustness action", "sac-fixed": "SAC, residual action",
                  "sac-robustness": "SAC, robustness action"}
"""The README's columns: a group label and its column's name (labels of one name share the column, the
first found in a structure filling it)."""
FIXED_COLUMNS = list(dict.fromkeys(FIXED_POLICIES.values()))
FIXED_HEADER = "| structure | oracle | best rule | " + " | ".join(f"{name} - best rule" for name in FIXED_COLUMNS) + " |"


def fixed_table(path: Path = FIXED_REGIMES) -> str:
    """The fixed mode at v3's default regime: per structure, the oracle, the best rule and each of
    :data:`FIXED_POLICIES`' paired difference to the best rule with its violation rate ("-" where a
    policy was not trained on the structure)."""
    lines = _head(FIXED_HEADER)
    for regime in _regimes(path):
        best, costs, rates = regime["best_rule"], regime["mean_cost"], regime["violation_rate"]
        cells = [f"| {_structure(regime)}", _cell(costs["oracle"]), f"`{best}` {_cell(costs[best])}"]
        found = regime["agents_to_rules"]
        for name in FIXED_COLUMNS:
            label = next((label for label, named in FIXED_POLICIES.items() if named == name and label in found), None)
            cells.append("-" if label is None else f"{_cell(found[label]['best_rule'])}, {100 * rates[label]:.1f}%")
        lines.append(" | ".join(cells) + " |")
    return "\n".join(lines)


OWN, BASE = "learned-plan-own-3000", "learned-plan-cert-3000"
OWN_HEADER = ("| structure | noise | production price | best rule | certified, `plan-best`'s plan | certified, own plan "
              "| its plan | its violations | own plan - best rule | own plan - `plan-best`'s plan |")


def _own_plan(regime: dict) -> str:
    """The plan of ``learned-plan-own-3000`` in a regime, from its seed-0 run's manifest in the committed sweep."""
    for sweep in regime["sweep"].split(" + "):
        manifest = RESULTS / sweep / "runs" / f"{OWN}-{regime['env']}-s0" / "learned_rule.json"
        if exists(manifest):
            return str(read_json(manifest)["env_kwargs"]["plan"])
    raise FileNotFoundError(f"no run of {OWN} on {regime['env']} among the sweeps {regime['sweep']}")


def own_plan_table(path: Path = OWN_REGIMES) -> str:
    """The certified learned plan with the plan chosen for the learned design (``learned-plan-own-3000``)
    against the best rule and against ``learned-plan-cert-3000`` (``BASE``, the same learner on the base rule's
    best plan), one row per regime of a ``regimes.json`` where it was trained."""
    lines = _head(OWN_HEADER)
    for regime in _regimes(path):
        costs = regime["mean_cost"]
        if OWN not in costs:
            continue
        best = regime["best_rule"]
        base = _differences(regime, OWN).get(BASE)
        lines.append(" | ".join((
            "| " + " | ".join(_regime_cells(regime)), f"`{best}` {_cell(costs[best])}",
            _cell(costs[BASE]) if BASE in costs else "-", _cell(costs[OWN]),
            _own_plan(regime), f"{100 * regime['violation_rate'][OWN]:.1f}%",
            _cell(regime["agents_to_rules"][OWN]["best_rule"]), f"{_cell(base) if base else '-'} |",
        )))
    return "\n".join(lines)


def tables(which: str = "headline", regimes: Path | None = None) -> str:
    """The table(s) of ``which`` (``headline``, ``rl``, ``fixed`` or ``own``) from ``regimes`` (default: the
    committed study's ``regimes.json``)."""
    if which == "own":
        return own_plan_table(regimes or OWN_REGIMES)
    if which == "fixed":
        return fixed_table(regimes or FIXED_REGIMES)
    if which == "rl":
        source = regimes or RL_REGIMES
        return rl_plan_table(source) + "\n\n" + behaviour_table(source)
    if which != "headline":
        raise ValueError(f"no table {which!r}: headline, rl, fixed or own")
    return headline_table(regimes or REGIMES)
