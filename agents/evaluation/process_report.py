"""The outputs of ``deadtime process``: the model, the table (md, csv, json) and the plots.

Rows are sorted by the process cost (:mod:`envs.process.scoring`), failures last, and ranked; each
row holds the controller, its figures on the process (IAE of the set-point and the load tests,
overshoot, the share of samples at an input limit) and on the identified model (``Ms``, the delay
margin).  The plots: ``experiments.png`` (each experiment's record with the model identified from
it) and ``responses.png`` (each policy's set-point and load tests on the process).
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluation.process_policies import ProcessPolicyResult
from agents.files.writer import write_figure
from envs.process.performance import RunProtocol
from envs.process.procedure import ProcessIdentification

__all__ = ["model_summary", "policy_rows", "markdown_table", "process_json", "write_outputs", "describe"]

_FIELDS = ("rank", "name", "role", "cost", "iae_setpoint", "iae_load", "overshoot", "saturated_fraction", "model_ms",
           "model_delay_margin", "parameter", "feasible", "controller", "stopped", "error", "note")


def _finite(value: Any) -> float | None:
    return float(value) if value is not None and math.isfinite(float(value)) else None


def model_summary(found: ProcessIdentification) -> dict[str, Any]:
    """The identified model and what it came from (JSON-ready, engineering units)."""
    i, point, relay = found.identification, found.operating_point, found.relay
    first = i.closed_loop
    commissioning = found.commissioning
    return {
        "operating_point": {"input": point.input, "output": point.output, "settle_time": point.settle_time,
                            "noise_std": point.noise_std},
        "gain": i.gain,
        "residence_time": i.residence_time,
        "tau": _finite(first.normalized_dead_time),
        "theta": _finite(first.theta),
        "fopdt": i.fopdt.to_dict(),
        "sopdt": i.sopdt.to_dict(),
        "mismatch_time": _finite(i.mismatch_time),
        "setpoint_step": found.setpoint_step,
        "open_loop_step": i.open_loop.height,
        "noise_ratio": found.noise_ratio,
        "experiment_time": i.experiment_time,
        "process_time": found.process_time,
        "relay": None if relay is None else {
            "converged": bool(relay.converged), "amplitude": relay.amplitude, "hysteresis": relay.hysteresis,
            "ultimate_gain": _finite(relay.ultimate_gain), "ultimate_period": _finite(relay.ultimate_period),
        },
        "commissioning": {"source": commissioning.source, "controller": commissioning.controller.to_dict(),
                          "model": None if commissioning.model is None else commissioning.model.to_dict()},
    }


def policy_rows(results: list[ProcessPolicyResult]) -> list[dict[str, Any]]:
    """One JSON-ready row per policy, sorted by cost (failures last) and ranked."""
    rows = []
    for r in results:
        s = r.score
        p = None if s is None else s.performance
        rows.append({
            "name": r.name,
            "role": r.role,
            "controller": None if r.controller is None else r.controller.to_dict(),
            "parameter": _finite(r.parameter),
            "cost": None if s is None else _finite(s.cost),
            "feasible": None if s is None else bool(s.feasible),
            "iae_setpoint": None if p is None else _finite(p.iae_setpoint),
            "iae_load": None if p is None else _finite(p.iae_load),
            "overshoot": None if p is None else _finite(p.overshoot),
            "saturated_fraction": None if p is None else _finite(p.saturated_fraction),
            "model_ms": None if s is None or not s.margins.stable else _finite(s.margins.ms),
            "model_delay_margin": None if s is None else _finite(s.margins.delay_margin),
            "model_stable": None if s is None else bool(s.margins.stable),
            "noise_floor": None if p is None else _finite(p.noise_floor),
            "stopped": None if p is None else p.stopped,
            "error": r.error,
            "note": r.note,
        })
    rows.sort(key=lambda row: (row["cost"] is None, row["cost"] if row["cost"] is not None else 0.0, row["name"]))
    for rank, row in enumerate(rows, start=1):
        row["rank"] = rank if row["cost"] is not None else None
    return rows


def _number(value: Any, digits: int = 3) -> str:
    if value is None:
        return "-"
    value = float(value)
    return f"{value:.{digits}g}" if abs(value) < 1000 else f"{value:.0f}"


def _controller_text(controller: dict | None) -> str:
    if controller is None:
        return "-"
    kind = controller["type"]
    if kind == "fppi":
        return f"fppi: tr {_number(controller['tr'])}, tf {_number(controller['tf'])}"
    if kind not in ("pid", "pid-series"):
        return kind
    parts = [f"kp {_number(controller['kp'])}", f"ti {_number(controller['ti'])}"]
    if controller.get("td"):
        parts.append(f"td {_number(controller['td'])}")
    return f"{kind}: " + ", ".join(parts)


def markdown_table(rows: list[dict[str, Any]], units: Any) -> str:
    """The table of the policies (Markdown), ``units`` the process's :class:`~envs.process.protocol.Units`."""
    iae = f"{units.output} {units.time}".strip()
    header = (f"| rank | policy | role | controller | cost | IAE set point ({iae}) | IAE load ({iae}) | overshoot | "
              f"at a limit | model Ms | model DM ({units.time or 'time'}) | note |")
    lines = [header, "|" + "---|" * 12]
    for row in rows:
        name = row["name"] if row["role"] == "rule" else f"**{row['name']}**"
        note = row["error"] or row["stopped"] or ("" if row["feasible"] else "outside Ms <= 2, DM >= 0.2 L on the model")
        if row["model_stable"] is False:
            note = "unstable on the model"
        if row.get("note"):
            note = f"{note}; {row['note']}" if note else row["note"]
        lines.append(
            f"| {row['rank'] or '-'} | {name} | {row['role']} | {_controller_text(row['controller'])} | {_number(row['cost'])} "
            f"| {_number(row['iae_setpoint'], 4)} | {_number(row['iae_load'], 4)} | {_number(row['overshoot'], 2)} "
            f"| {_number(row['saturated_fraction'], 2)} | {_number(row['model_ms'])} | {_number(row['model_delay_margin'])} "
            f"| {note} |"
        )
    return "\n".join(lines)


def process_json(found: ProcessIdentification, rows: list[dict[str, Any]], protocol: RunProtocol, extra: dict) -> dict:
    """``{"process", "model", "policies", "protocol", ...}`` (the ``--json`` object)."""
    return {"process": found.process, "model": model_summary(found), "policies": rows, "protocol": protocol.to_dict(), **extra}


def describe(found: ProcessIdentification, units: Any) -> list[str]:
    """The lines that say what was identified, and from what."""
    i, point, c = found.identification, found.operating_point, found.commissioning
    first, relay = i.closed_loop, found.relay
    u, y, t = units.input, units.output, units.time
    lines = [
        f"process {found.process}: operating point u0 = {point.input:g} {u}, y0 = {point.output:.4g} {y} "
        f"(steady after {point.settle_time:g} {t}), noise {point.noise_std:.3g} {y}".replace("  ", " "),
    ]
    if c.source == "given":
        lines.append(f"commissioning controller: the loop's existing controller, given: {json.dumps(c.controller.to_dict())}")
    else:
        m = c.model
        lines.append(f"commissioning controller: designed from a first open-loop step of {c.step.control[0]:g} {u} "
                     f"(moment FOPDT K = {m.gain:.4g}, T = {m.time_constant:.4g}, L = {m.dead_time:.4g} {t}; the "
                     f"environments' commissioning PI, Ms <= 1.4 on it): {json.dumps(c.controller.to_dict())}")
    lines.append(
        f"identified (closed-loop step of {found.setpoint_step:g} {y}, open-loop step of {i.open_loop.height:.4g} {u}): "
        f"K_n = {i.gain:.4g} {y}/{u}, T_ar = {i.residence_time:.4g} {t}, tau = {first.normalized_dead_time:.3g}, "
        f"theta = {first.theta:.3g}")
    f, s = i.fopdt, i.sopdt
    lines.append(f"  FOPDT (eq. 11): K = {f.gain:.4g}, T_n = {f.time_constant:.4g}, L_n = {f.dead_time:.4g} {t}; "
                 f"T_f_bar = {i.mismatch_time:.3g} {t} (eq. 22)")
    lines.append(f"  SOPDT (Gorez-Klan eq. 2-8): K = {s.gain:.4g}, T1 = {s.time_constants[0]:.4g}, "
                 f"T2 = {s.time_constants[1]:.4g}, D2 = {s.dead_time:.4g} {t}")
    if relay is not None:
        state = "periodic" if relay.converged else "not periodic"
        lines.append(f"  relay ({state}, d = {relay.amplitude:.3g} {u}, hysteresis {relay.hysteresis:.3g} {y}): "
                     f"K_u = {relay.ultimate_gain:.4g} {u}/{y}, T_u = {relay.ultimate_period:.4g} {t}")
    return lines


def _csv(rows: list[dict[str, Any]]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=_FIELDS, extrasaction="ignore")
    writer.writeheader()
    for row in rows:
        writer.writerow({**row, "controller": json.dumps(row["controller"])})
    return buffer.getvalue()


def write_outputs(out: Path, found: ProcessIdentification, results: list[ProcessPolicyResult], rows: list[dict],
                  data: dict, text: str, units: Any, plots: bool = True) -> list[Path]:
    """``results.md``, ``results.csv``, ``results.json`` and (``plots``) the two figures, in ``out``."""
    from agents.files.writer import write_json, write_text

    out.mkdir(parents=True, exist_ok=True)
    written = [write_text(out / "results.md", text + "\n"), write_text(out / "results.csv", _csv(rows)),
               write_json(out / "results.json", data)]
    if plots:
        written += [experiments_plot(found, units, out / "experiments.png"), responses_plot(results, units, out / "responses.png")]
    return written


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def experiments_plot(found: ProcessIdentification, units: Any, path: Path) -> Path:
    """Each experiment's measured output (deviation from the operating point) with the model fitted to
    it: the first step with its moment FOPDT, the open-loop step with the FOPDT (eq. 11) and SOPDT
    models, the closed-loop step with its set point, the relay."""
    plt = _pyplot()
    i = found.identification
    panels = [("closed-loop step", i.closed_loop), ("open-loop step", i.open_loop)]
    if found.commissioning.step is not None:
        panels.insert(0, ("first open-loop step", found.commissioning.step))
    if found.relay is not None:
        panels.append(("relay", found.relay))
    figure, axes = plt.subplots(len(panels), 1, figsize=(8, 2.6 * len(panels)), squeeze=False)
    for ax, (title, run) in zip(axes[:, 0], panels):
        t = np.asarray(run.timepts)
        ax.plot(t, run.output, lw=0.8, color="0.4", label="measured")
        if title == "first open-loop step":
            height = float(run.control[0])
            ax.plot(t, height * found.commissioning.model.step_response(t), lw=1.2, label="moment FOPDT")
        elif title == "open-loop step":
            ax.plot(t, run.height * i.fopdt.step_response(t), lw=1.2, label="FOPDT (eq. 11)")
            ax.plot(t, run.height * i.sopdt.step_response(t), lw=1.2, ls="--", label="SOPDT (eq. 2-8)")
        elif title == "closed-loop step":
            ax.axhline(run.amplitude, color="k", lw=0.6, ls=":", label="set point")
        ax.set_title(title, fontsize=9)
        ax.set_ylabel(f"y - y0 ({units.output})", fontsize=8)
        ax.legend(fontsize=7)
    axes[-1, 0].set_xlabel(f"t ({units.time})", fontsize=8)
    figure.suptitle(f"{found.process}: experiments and fitted models", fontsize=10)
    figure.tight_layout()
    write_figure(path, figure, 90)
    plt.close(figure)
    return path


def responses_plot(results: list[ProcessPolicyResult], units: Any, path: Path) -> Path:
    """The set-point and load tests of every policy on the process: rules thin and grey, the
    commissioning controller, the oracle and the agents in colour."""
    plt = _pyplot()
    figure, axes = plt.subplots(2, 2, figsize=(11, 6.5), sharex="col")
    for r in results:
        if r.score is None or r.score.performance is None:
            continue
        p = r.score.performance
        style = dict(lw=0.5, color="0.7") if r.role == "rule" else dict(lw=1.4, label=r.name)
        for column, record in enumerate((p.setpoint_run, p.load_run)):
            if record.timepts.size:
                axes[0, column].plot(record.timepts, record.output, **style)
                axes[1, column].plot(record.timepts, record.control, **style)
    axes[0, 0].set_title("set-point test", fontsize=9)
    axes[0, 1].set_title("load test", fontsize=9)
    for column in (0, 1):
        axes[0, column].set_ylabel(f"y ({units.output})", fontsize=8)
        axes[1, column].set_ylabel(f"u ({units.input})", fontsize=8)
        axes[1, column].set_xlabel(f"t ({units.time})", fontsize=8)
    axes[0, 0].plot([], [], lw=0.5, color="0.7", label="rules")
    axes[0, 0].legend(fontsize=7)
    figure.tight_layout()
    write_figure(path, figure, 90)
    plt.close(figure)
    return path
