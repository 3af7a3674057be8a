"""``deadtime process``: the identification procedure, the rules, the oracle and agents on a real process.

``--process tclab`` is the TCLab emulator (:class:`envs.process.tclab_process.TCLabProcess`);
``--process module:factory`` calls ``factory()`` of an importable module (the working directory is
searched too) for a user's own process, anything with the interface of
:class:`envs.process.protocol.Process`.  The command runs the procedure
(:func:`envs.process.procedure.identify_process`), prints the identified model and then, for each
policy, its controller, its tests on the process itself and its robustness on the identified model
(:mod:`agents.evaluation.process_policies`, :mod:`envs.process.scoring`), as a table sorted by cost;
``--out`` writes it as ``results.{md,csv,json}`` with ``experiments.png`` and ``responses.png``.

Bad input (an unknown process, a factory that cannot be imported or raises, an object that is not
a process, amplitudes that leave the input limits, a measurement that is not a number during the
identification) is one line naming what is wrong, exit status 2.  A measurement that is not a
number during a policy's tests stops that test; its row says so and the others run.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from agents.commands.arguments import CommandError, load_json_argument, require_directory
from agents.user_code import user_function

__all__ = ["add_arguments", "run", "make_process"]

DEFAULT_POLICIES = "all-rules,oracle"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the options of ``deadtime process``."""
    parser.add_argument("--process", required=True, help="'tclab' (the TCLab emulator) or module:factory (a user's process)")
    parser.add_argument("--policies", default=DEFAULT_POLICIES,
                        help=f"comma-separated: rule names, all-rules (every rule for self-regulating plants), oracle (the PID's mu "
                        f"searched on the process), oracle-fppi (the FPPI's T_r), agent paths or NAME=PATH (default "
                        f"{DEFAULT_POLICIES}); the commissioning controller is always the first row; loading an agent runs "
                        "pickled code from its folder: load only agents you trust")
    parser.add_argument("--controller", help="the loop's existing controller, JSON {\"type\": \"pid\"|\"pid-series\", \"kp\", "
                        "\"ti\", ...} in the process's units (default: designed from a first open-loop step)")
    parser.add_argument("--operating-input", type=float, help="the input of the operating point (default: the process's)")
    parser.add_argument("--setpoint-step", type=float, help="set-point step of the experiment and of the test, output units")
    parser.add_argument("--input-step", type=float, help="input step of the first open-loop step, input units")
    parser.add_argument("--load-step", type=float, help="load step of the load test, load units, inside the load input's "
                        "range (0 to 100 %% heater 2 for the TCLab)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the process's noise (an integer >= 0, default 0)")
    parser.add_argument("--out", help="output directory for results.{md,csv,json} and the plots")
    parser.add_argument("--no-plots", action="store_true", help="write the tables only")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def make_process(text: str) -> Any:
    """The process named by ``--process``: ``tclab`` or ``module:factory``.

    Raises
    ------
    CommandError
        Naming what is wrong: an unknown name, a module that cannot be imported, a missing factory,
        a factory that raises (with its exception), or an object without the Process interface.
    """
    from envs.process.protocol import check_process

    if text == "tclab":
        from envs.process.tclab_process import TCLabProcess

        return TCLabProcess()
    module_name, colon, factory_name = text.partition(":")
    if not colon or not module_name or not factory_name:
        raise CommandError(f"--process: unknown process {text!r}; give 'tclab' or module:factory (a function that returns a process)")
    try:
        factory = user_function(text, "--process")
    except ValueError as error:
        raise CommandError(str(error)) from None
    try:
        process = factory()
    except Exception as error:  # noqa: BLE001  (a factory that raises is bad input, named)
        raise CommandError(f"--process: {text}() raised {type(error).__name__}: {error}") from None
    try:
        return check_process(process)
    except ValueError as error:
        raise CommandError(f"--process: {text}() returned no valid process: {error}") from None


def _controller(text: str | None) -> Any:
    if text is None:
        return None
    from envs.systems.controllers import PID, SeriesPID, controller_from_dict

    controller = controller_from_dict(load_json_argument(text, "--controller"))
    if not isinstance(controller, PID | SeriesPID):
        raise CommandError(f"--controller must be a PI/PID (type 'pid' or 'pid-series'), got {controller.to_dict()['type']!r}")
    return controller


def _load_step(process: Any, value: float | None) -> float:
    """``--load-step`` (default the process's), inside the range of the process's load input."""
    from envs.process.protocol import check_load_step

    if value is None:
        return process.load_step
    try:
        return check_load_step(process, value, "--load-step")
    except ValueError as error:
        raise CommandError(str(error)) from None


def run(args: argparse.Namespace) -> int:
    """Run ``deadtime process``; bad input is a ValueError (one line, exit status 2)."""
    from agents.evaluation.policies import parse_policies
    from agents.evaluation.process_policies import evaluate_policies
    from agents.evaluation.process_report import describe, markdown_table, policy_rows, process_json, write_outputs
    from envs.process.performance import RunProtocol
    from envs.process.procedure import identify_process
    from envs.threads import single_threaded

    started = time.perf_counter()
    if args.seed < 0:
        raise CommandError(f"--seed must be an integer >= 0, got {args.seed}")
    if args.out is not None:
        require_directory(args.out)
    items = [item.strip() for item in args.policies.split(",")]
    fppi_oracle = "oracle-fppi" in items
    others = ",".join(item for item in items if item != "oracle-fppi")
    # every rule for self-regulating plants: the PID rules, the mu rules and the FPPI's T_r rules
    specs = parse_policies(others, "fppi") if others or not fppi_oracle else []
    controller = _controller(args.controller)
    process = make_process(args.process)
    try:
        load_step = _load_step(process, args.load_step)
        found = single_threaded(identify_process)(
            process, seed=args.seed, controller=controller, setpoint_step=args.setpoint_step,
            input_step=args.input_step, operating_input=args.operating_input,
        )  # fmt: skip
        protocol = RunProtocol.from_identification(found, load_step, seed=args.seed)
        identified = time.perf_counter() - started
        results = single_threaded(evaluate_policies)(process, found, protocol, specs, fppi_oracle)
    finally:
        if hasattr(process, "close"):
            process.close()
    rows = policy_rows(results)
    elapsed = time.perf_counter() - started
    timing = {"identification_s": round(identified, 3), "wall_time_s": round(elapsed, 3)}
    data = process_json(found, rows, protocol, {"timing": timing})
    lines = describe(found, process.units)
    table = markdown_table(rows, process.units)
    agents = [row for row in rows if row["role"] == "agent"]
    ranked = sum(row["rank"] is not None for row in rows)
    summary = [(f"{row['name']} (agent) ranks {row['rank']} of {ranked}" if row["rank"] else
                f"{row['name']} (agent): {row['error'] or row['stopped']}") + (f" ({row['note']})" if row.get("note") else "")
               for row in agents]
    text = "\n".join([*lines, "", table, "", *summary, f"({elapsed:.1f} s: identification {identified:.1f} s)"]).strip()
    if args.out is not None:
        write_outputs(Path(args.out), found, results, rows, data, text, process.units, plots=not args.no_plots)
    if args.json:
        print(json.dumps(data))
    else:
        print(text)
        if args.out is not None:
            print(f"wrote {Path(args.out) / 'results.md'} (and .csv, .json{'' if args.no_plots else ', plots'})", file=sys.stderr)
    return 0
